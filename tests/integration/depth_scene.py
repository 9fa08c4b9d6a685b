"""The open box of box_scene.py seen by a depth camera 2 m above the opening, looking straight
down, rendered by exact ray casting with numpy (the C++ simulator is not used): a z-depth image,
its encodings (16-bit PNG in millimetres, 32-bit float TIFF in metres, written here from the
formats' specifications) and the same returns back-projected as a cloud."""
import struct
import zlib

import numpy as np

import box_scene

WIDTH, HEIGHT = 320, 240
FX = FY = 250.0
CX, CY = (WIDTH - 1) / 2.0, (HEIGHT - 1) / 2.0
ABOVE_M = 2.0  # camera centre above the opening plane
GROUND_Z = -box_scene.DEPTH - box_scene.WALL - 0.3


def intrinsics():
    return {"fx": FX, "fy": FY, "cx": CX, "cy": CY}


def to_camera(points_box):
    """Box frame (z up, opening at z = 0) -> camera frame (x right, y down, z forward)."""
    p = np.asarray(points_box, dtype=float)
    return np.stack([p[..., 0], -p[..., 1], ABOVE_M - p[..., 2]], -1)


def opening_corners():
    return [tuple(c) for c in to_camera(np.array(box_scene.opening_corners()))]


def _rays():
    u, v = np.meshgrid(np.arange(WIDTH), np.arange(HEIGHT))
    return (u - CX) / FX, (v - CY) / FY  # camera x, y at z = 1


def render(fill_m, noise_m=0.0, seed=0):
    """Z-depth [m] per pixel (HEIGHT x WIDTH): the nearest of the soil (or floor), the inner
    walls, the rim and the ground, plus Gaussian noise."""
    x, y = _rays()
    bx, by = x, -y  # box-frame direction per unit of depth (z falls by 1)
    hx, hy = box_scene.INNER_L / 2, box_scene.INNER_W / 2
    ox, oy = hx + box_scene.WALL, hy + box_scene.WALL
    soil_z = -box_scene.DEPTH + fill_m
    best = np.full(x.shape, np.inf)

    def take(t, valid):
        np.copyto(best, np.minimum(best, np.where(valid & (t > 0), t, np.inf)))

    def at(t):
        return bx * t, by * t, ABOVE_M - t  # box-frame hit point at depth t

    t = np.full(x.shape, ABOVE_M - soil_z)
    px, py, _ = at(t)
    take(t, (np.abs(px) < hx) & (np.abs(py) < hy))
    t = np.full(x.shape, ABOVE_M)
    px, py, _ = at(t)
    take(t, (np.abs(px) < ox) & (np.abs(py) < oy) & ~((np.abs(px) < hx) & (np.abs(py) < hy)))
    t = np.full(x.shape, ABOVE_M - GROUND_Z)
    take(t, np.ones(x.shape, bool))
    with np.errstate(divide="ignore", invalid="ignore"):
        for wall, direction, across, half in ((hx, bx, by, hy), (-hx, bx, by, hy),
                                              (hy, by, bx, hx), (-hy, by, bx, hx)):
            t = wall / direction
            _, _, pz = at(t)
            take(t, (np.abs(across * t) < half) & (pz <= 0.0) & (pz >= soil_z))
    rng = np.random.default_rng(seed)
    return best + rng.normal(0.0, noise_m, best.shape)


def back_project_as_core(z_mm):
    """The points core/depth makes of a 16-bit millimetre image, float for float: each ray
    (u - cx) / fx in double rounded to float, the depth count times the unit 0.001f in float,
    their product in float."""
    u, v = np.meshgrid(np.arange(WIDTH), np.arange(HEIGHT))
    x = ((u - CX) / FX).astype(np.float32)
    y = ((v - CY) / FY).astype(np.float32)
    z = np.asarray(z_mm).astype(np.float32) * np.float32(0.001)
    keep = z > 0
    return np.stack([x[keep] * z[keep], y[keep] * z[keep], z[keep]], 1)


def millimetres(z):
    return np.clip(np.rint(z * 1000.0), 0, 65535).astype(np.uint16)


def _png_chunk(kind, data):
    return (struct.pack(">I", len(data)) + kind + data +
            struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))


def encode_png(image):
    """PNG (ISO/IEC 15948) of a 2-D uint8 or uint16 array, grey, filter 0 on every row."""
    image = np.asarray(image)
    depth = 16 if image.dtype == np.uint16 else 8
    rows = image.astype(">u2" if depth == 16 else "u1")
    raw = b"".join(b"\x00" + row.tobytes() for row in rows)
    header = struct.pack(">IIBBBBB", image.shape[1], image.shape[0], depth, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", header) +
            _png_chunk(b"IDAT", zlib.compress(raw)) + _png_chunk(b"IEND", b""))


def encode_float_tiff(image):
    """Baseline little-endian TIFF 6.0 of a 2-D float32 array: one strip, no compression."""
    image = np.asarray(image, dtype="<f4")
    height, width = image.shape
    data = image.tobytes()
    entries = [  # tag, type (3 SHORT, 4 LONG), value
        (256, 4, width), (257, 4, height), (258, 3, 32), (259, 3, 1), (262, 3, 1),
        (273, 4, 8), (277, 3, 1), (278, 4, height), (279, 4, len(data)), (339, 3, 3)]
    ifd = struct.pack("<H", len(entries))
    for tag, kind, value in entries:
        ifd += struct.pack("<HHI", tag, kind, 1)
        ifd += struct.pack("<HH", value, 0) if kind == 3 else struct.pack("<I", value)
    ifd += struct.pack("<I", 0)
    return b"II*\x00" + struct.pack("<I", 8 + len(data)) + data + ifd
