"""A box container with its CAD mesh, with numpy only: an independent check of mesh
registration (the C++ simulator is not used). Inside 1.6 x 0.8 x 0.6 m, 3 cm walls and floor,
a 5 cm rim, made of axis-aligned slabs; the mesh is their faces split into triangles at most
10 cm wide, written as binary STL in a CAD frame of its own (origin at a bottom corner). Scans
cast rays from a sensor 2.5 m above the opening, off to one side and turned, against the slabs
and a flat load: exact truth, soil volume = L * W * h."""
import struct

import numpy as np

INNER_L = 1.6  # x [m]
INNER_W = 0.8  # y [m]
DEPTH = 0.6  # opening plane (z = 0) to the floor
WALL = 0.03  # walls and floor
RIM = 0.05  # the rim's overhang beyond the walls, WALL thick
STRUCK_M3 = INNER_L * INNER_W * DEPTH
RANGE_NOISE_M = 0.003

_HX, _HY = INNER_L / 2, INNER_W / 2
_OX, _OY = _HX + WALL, _HY + WALL  # the walls' outer faces
_RX, _RY = _OX + RIM, _OY + RIM  # the rim's outer edge
# The CAD frame: the container frame (opening centred at z = 0, z up) moved so that the
# mesh's lowest corner is its origin.
MESH_OFFSET = np.array([_RX, _RY, DEPTH + WALL])


def slabs():
    """The container as (low, high) corners of axis-aligned boxes, container frame."""
    return [
        ((-_OX, -_OY, -DEPTH - WALL), (_OX, _OY, -DEPTH)),  # floor
        ((_HX, -_OY, -DEPTH), (_OX, _OY, 0.0)),  # walls at +x and -x
        ((-_OX, -_OY, -DEPTH), (-_HX, _OY, 0.0)),
        ((-_HX, _HY, -DEPTH), (_HX, _OY, 0.0)),  # walls at +y and -y
        ((-_HX, -_OY, -DEPTH), (_HX, -_HY, 0.0)),
        ((_OX, -_RY, -WALL), (_RX, _RY, 0.0)),  # rim at +x and -x
        ((-_RX, -_RY, -WALL), (-_OX, _RY, 0.0)),
        ((-_OX, _OY, -WALL), (_OX, _RY, 0.0)),  # rim at +y and -y
        ((-_OX, -_RY, -WALL), (_OX, -_OY, 0.0)),
    ]


def opening_corners():
    """Container frame, counter-clockwise seen from above."""
    return [(-_HX, -_HY, 0.0), (_HX, -_HY, 0.0), (_HX, _HY, 0.0), (-_HX, _HY, 0.0)]


def mesh_corners():
    """The same corners in the mesh's (CAD) frame."""
    return [tuple(np.asarray(c) + MESH_OFFSET) for c in opening_corners()]


def _box_triangles(low, high, cell=0.1):
    """Each face of the box as a grid of cells at most `cell` wide, two triangles a cell,
    counter-clockwise seen from outside (a remeshed CAD surface: vertices inside the opening
    too)."""
    low, high = np.asarray(low, float), np.asarray(high, float)
    tris = []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        nu = max(1, int(np.ceil((high[u] - low[u]) / cell)))
        nv = max(1, int(np.ceil((high[v] - low[v]) / cell)))
        us = np.linspace(low[u], high[u], nu + 1)
        vs = np.linspace(low[v], high[v], nv + 1)
        for side, w in ((1, high[axis]), (-1, low[axis])):
            for i in range(nu):
                for j in range(nv):
                    quad = []
                    for a, b in ((us[i], vs[j]), (us[i + 1], vs[j]), (us[i + 1], vs[j + 1]),
                                 (us[i], vs[j + 1])):
                        p = np.empty(3)
                        p[axis], p[u], p[v] = w, a, b
                        quad.append(p)
                    # (u, v, axis) is right-handed: counter-clockwise in (u, v) faces +axis.
                    if side < 0:
                        quad = quad[::-1]
                    tris += [np.array([quad[0], quad[1], quad[2]]),
                             np.array([quad[0], quad[2], quad[3]])]
    return tris


def mesh_triangles():
    """[N, 3, 3] triangles of the container in the mesh's frame."""
    tris = [t for low, high in slabs() for t in _box_triangles(low, high)]
    return np.asarray(tris) + MESH_OFFSET


def encode_stl(triangles):
    """Binary STL: 80-byte header, count, 50-byte facets (normal, 3 corners, attribute)."""
    out = bytearray(b"soilvol test box".ljust(80, b" "))
    out += struct.pack("<I", len(triangles))
    for t in np.asarray(triangles, dtype=np.float64):
        n = np.cross(t[1] - t[0], t[2] - t[0])
        n = n / (np.linalg.norm(n) or 1.0)
        out += struct.pack("<12fH", *n, *t[0], *t[1], *t[2], 0)
    return bytes(out)


def mesh_stl():
    return encode_stl(mesh_triangles())


def _rotation_z(deg):
    a = np.radians(deg)
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1.0]])


# Where the container stands before the sensor: x_scan = R x_container + t. The sensor is
# 2.5 m above the opening and 1.3 m off its centre along -x, so that it sees the outside of
# the wall at -x and the inside of the others; the container is turned by 12 degrees.
R_SCAN_CONTAINER = _rotation_z(12.0)
T_SCAN_CONTAINER = R_SCAN_CONTAINER @ np.array([1.1, 0.75, 0.0]) + np.array([0.0, 0.0, -2.5])


def mesh_pose():
    """The mesh frame in the scan frame: (position [3], quaternion w, x, y, z)."""
    position = T_SCAN_CONTAINER - R_SCAN_CONTAINER @ MESH_OFFSET
    half = np.radians(12.0) / 2
    return position, (np.cos(half), 0.0, 0.0, np.sin(half))


def pose_json():
    position, (w, x, y, z) = mesh_pose()
    return {"positionM": {"x": position[0], "y": position[1], "z": position[2]},
            "orientation": {"w": w, "x": x, "y": y, "z": z}}


def to_scan(points):
    return np.asarray(points) @ R_SCAN_CONTAINER.T + T_SCAN_CONTAINER


def scan_opening_corners():
    return [tuple(p) for p in to_scan(opening_corners())]


def _ray_boxes(origin, dirs, boxes):
    """Distance to the first box each ray (origin + t dir) enters; inf for a miss."""
    best = np.full(len(dirs), np.inf)
    safe = np.where(np.abs(dirs) < 1e-12, 1e-12, dirs)
    for low, high in boxes:
        t1 = (np.asarray(low) - origin) / safe
        t2 = (np.asarray(high) - origin) / safe
        near = np.minimum(t1, t2).max(axis=1)
        far = np.maximum(t1, t2).min(axis=1)
        hit = (far >= np.maximum(near, 0.0)) & (near > 0.0)
        best = np.where(hit & (near < best), near, best)
    return best


def scan(fill_m=0.0, step=0.01, seed=0):
    """Points [N, 3] (scan frame) a sensor at the origin sees of the container holding flat
    soil `fill_m` deep: rays through a grid of `step` over the opening plane around the
    container, each return moved along its ray by the sensor's range noise."""
    rng = np.random.default_rng(seed)
    margin = _RX + 0.3
    a = np.arange(-margin, margin, step)
    b = np.arange(-(_RY + 0.3), _RY + 0.3, step)
    ga, gb = np.meshgrid(a, b)
    targets = to_scan(np.stack([ga.ravel(), gb.ravel(), np.zeros(ga.size)], 1))
    dirs = targets / np.linalg.norm(targets, axis=1, keepdims=True)
    # In the container frame: the sensor at origin_c, the rays turned back.
    origin_c = -R_SCAN_CONTAINER.T @ T_SCAN_CONTAINER
    dirs_c = dirs @ R_SCAN_CONTAINER
    boxes = slabs()
    if fill_m > 0:
        boxes.append(((-_HX, -_HY, -DEPTH), (_HX, _HY, -DEPTH + fill_m)))
    t = _ray_boxes(origin_c, dirs_c, boxes)
    seen = np.isfinite(t)
    t = t[seen] + rng.normal(0.0, RANGE_NOISE_M, seen.sum())
    return dirs[seen] * t[:, None]


def truth_m3(fill_m):
    return INNER_L * INNER_W * fill_m
