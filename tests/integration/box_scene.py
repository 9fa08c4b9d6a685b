"""An open box container scanned from above, with numpy only: an independent check of the
engine's volumes (the C++ simulator is not used). Exact truth: soil volume = L * W * h."""
import struct

import numpy as np

INNER_L = 1.20  # x [m]
INNER_W = 0.80  # y [m]
DEPTH = 0.50  # opening plane (z = 0) to the floor
WALL = 0.06  # wall thickness / rim width
STRUCK_M3 = INNER_L * INNER_W * DEPTH


def _grid(x0, x1, y0, y1, step):
    xs = np.arange(x0 + step / 2, x1, step)
    ys = np.arange(y0 + step / 2, y1, step)
    gx, gy = np.meshgrid(xs, ys)
    return gx.ravel(), gy.ravel()


def _wall(a0, a1, z0, z1, step):
    a = np.arange(a0 + step / 2, a1, step)
    z = np.arange(z0 + step / 2, z1, step)
    ga, gz = np.meshgrid(a, z)
    return ga.ravel(), gz.ravel()


def box_scan(fill_m=0.0, step=0.012, noise_m=0.003, seed=0, shift=(0.0, 0.0, 0.0), yaw_deg=0.0):
    """Points [N, 3] of the box with flat soil `fill_m` deep, seen by a sensor 2.5 m above
    (its frame: z up from the opening plane at z = 2.5 m below the sensor... kept simple: the
    scan frame is the box frame moved by `shift` and turned by `yaw_deg`)."""
    rng = np.random.default_rng(seed)
    hx, hy = INNER_L / 2, INNER_W / 2
    parts = []
    # Soil or floor, and the inner walls above it.
    gx, gy = _grid(-hx, hx, -hy, hy, step)
    parts.append(np.stack([gx, gy, np.full_like(gx, -DEPTH + fill_m)], 1))
    top = -DEPTH + fill_m
    if top < 0:
        for sign in (-1, 1):
            a, z = _wall(-hx, hx, top, 0.0, step)
            parts.append(np.stack([a, np.full_like(a, sign * hy), z], 1))
            a, z = _wall(-hy, hy, top, 0.0, step)
            parts.append(np.stack([np.full_like(a, sign * hx), a, z], 1))
    # Rim: a flat ring WALL wide around the opening.
    gx, gy = _grid(-hx - WALL, hx + WALL, -hy - WALL, hy + WALL, step)
    ring = (np.abs(gx) > hx) | (np.abs(gy) > hy)
    parts.append(np.stack([gx[ring], gy[ring], np.zeros(ring.sum())], 1))
    # Outer walls (the sensor sees them at a slant) and a mounting plate below one end.
    for sign in (-1, 1):
        a, z = _wall(-hx - WALL, hx + WALL, -DEPTH - WALL, 0.0, step)
        parts.append(np.stack([a, np.full_like(a, sign * (hy + WALL)), z], 1))
        a, z = _wall(-hy - WALL, hy + WALL, -DEPTH - WALL, 0.0, step)
        parts.append(np.stack([np.full_like(a, sign * (hx + WALL)), a, z], 1))
    gx, gy = _grid(hx + WALL, hx + WALL + 0.3, -0.2, 0.2, step)
    parts.append(np.stack([gx, gy, np.full_like(gx, -0.25)], 1))
    points = np.concatenate(parts)
    points += rng.normal(0.0, noise_m, points.shape)
    yaw = np.radians(yaw_deg)
    rot = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    return points @ rot.T + np.asarray(shift)


def opening_corners():
    hx, hy = INNER_L / 2, INNER_W / 2
    return [(-hx, -hy, 0.0), (hx, -hy, 0.0), (hx, hy, 0.0), (-hx, hy, 0.0)]


def encode_ply(points):
    """Binary little-endian PLY with float x, y, z."""
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(points)}\n"
        "property float x\nproperty float y\nproperty float z\nend_header\n"
    ).encode()
    return header + np.asarray(points, dtype="<f4").tobytes()


def encode_ascii_ply(points):
    lines = [
        "ply",
        "format ascii 1.0",
        f"element vertex {len(points)}",
        "property float x",
        "property float y",
        "property float z",
        "end_header",
    ]
    lines += [f"{x:.5f} {y:.5f} {z:.5f}" for x, y, z in points]
    return ("\n".join(lines) + "\n").encode()


if __name__ == "__main__":
    pts = box_scan(0.2)
    print(len(pts), struct.calcsize("<f"), STRUCK_M3)
