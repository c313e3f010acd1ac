"""Small rigid-body helpers for the simulated world: poses, boxes, overlap tests.

Lengths are millimetres, angles at the edges degrees; rotations are 3x3 or
4x4 homogeneous matrices in the robot base frame (z up).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

#: The eight corners of a unit box centred at the origin, (8, 3), in the order
#: bottom face (z = -1/2) counter-clockwise seen from above, then the top face.
UNIT_BOX = 0.5 * np.array(
    [
        [-1, -1, -1],
        [1, -1, -1],
        [1, 1, -1],
        [-1, 1, -1],
        [-1, -1, 1],
        [1, -1, 1],
        [1, 1, 1],
        [-1, 1, 1],
    ],
    dtype=float,
)

#: Faces of :data:`UNIT_BOX` as corner indices, outward normals counter-clockwise.
BOX_FACES = (
    (4, 5, 6, 7),  # top (+z)
    (0, 3, 2, 1),  # bottom (-z)
    (0, 1, 5, 4),  # -y
    (1, 2, 6, 5),  # +x
    (2, 3, 7, 6),  # +y
    (3, 0, 4, 7),  # -x
)


def rot_z(yaw_rad: float) -> np.ndarray:
    """3x3 rotation about z by ``yaw_rad`` radians."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rpy_matrix(roll_deg: float, pitch_deg: float, yaw_deg: float) -> np.ndarray:
    """3x3 rotation R = Rz(yaw) Ry(pitch) Rx(roll) from angles in degrees."""
    r, p, y = np.radians([roll_deg, pitch_deg, yaw_deg])
    cr, sr, cp, sp = math.cos(r), math.sin(r), math.cos(p), math.sin(p)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    return rot_z(y) @ ry @ rx


def pose(rotation: npt.ArrayLike, translation: npt.ArrayLike) -> np.ndarray:
    """4x4 homogeneous transform from a 3x3 rotation and a translation (mm)."""
    t = np.eye(4)
    t[:3, :3] = rotation
    t[:3, 3] = translation
    return t


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray | None = None) -> np.ndarray:
    """Camera pose (4x4, OpenCV axes: x right, y down, z forward) at ``eye`` looking at ``target``.

    ``up`` is the world direction that appears upwards in the image (default +x
    for a camera looking straight down, else +z).
    """
    eye = np.asarray(eye, dtype=float)
    forward = np.asarray(target, dtype=float) - eye
    norm = np.linalg.norm(forward)
    if norm < 1e-9:
        raise ValueError("camera position and look_at target coincide")
    z = forward / norm
    if up is None:
        up = np.array([1.0, 0.0, 0.0]) if abs(z[2]) > 0.99 else np.array([0.0, 0.0, 1.0])
    y = -np.asarray(up, dtype=float)
    y = y - z * np.dot(y, z)
    if np.linalg.norm(y) < 1e-9:
        raise ValueError("the camera's up direction is parallel to its view direction")
    y /= np.linalg.norm(y)
    x = np.cross(y, z)
    return pose(np.column_stack([x, y, z]), eye)


def box_corners(transform: np.ndarray, size: np.ndarray) -> np.ndarray:
    """World corners (8, 3) of a box of ``size`` (mm) centred at ``transform``'s origin."""
    local = UNIT_BOX * np.asarray(size, dtype=float)
    return local @ transform[:3, :3].T + transform[:3, 3]


def obb_penetration(ta: np.ndarray, sa: np.ndarray, tb: np.ndarray, sb: np.ndarray) -> float:
    """Penetration depth (mm) of two oriented boxes by the separating-axis theorem.

    Boxes are given by centre poses ``ta``, ``tb`` (4x4) and sizes ``sa``, ``sb``.
    Returns 0 when they are apart or only touch, else the smallest overlap
    along the 15 candidate axes (an upper bound of how far they interpenetrate).
    """
    ra, rb = ta[:3, :3], tb[:3, :3]
    ha, hb = 0.5 * np.asarray(sa, dtype=float), 0.5 * np.asarray(sb, dtype=float)
    d = tb[:3, 3] - ta[:3, 3]
    # Boxes farther apart than their circumscribed spheres reach cannot overlap; most pairs
    # a world checks every tick are, and this spares them the fifteen axes.
    if float(np.dot(d, d)) >= (float(np.linalg.norm(ha)) + float(np.linalg.norm(hb))) ** 2:
        return 0.0
    axes = [ra[:, i] for i in range(3)] + [rb[:, i] for i in range(3)]
    for i in range(3):
        for j in range(3):
            c = np.cross(ra[:, i], rb[:, j])
            n = np.linalg.norm(c)
            if n > 1e-9:
                axes.append(c / n)
    best = math.inf
    for axis in axes:
        proj_a = np.sum(ha * np.abs(ra.T @ axis))
        proj_b = np.sum(hb * np.abs(rb.T @ axis))
        overlap = proj_a + proj_b - abs(float(np.dot(d, axis)))
        if overlap <= 0:
            return 0.0
        best = min(best, overlap)
    return float(best)


def footprint_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """True when two convex polygons (k, 2) in the table plane overlap with positive area."""
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        normals = np.column_stack([-edges[:, 1], edges[:, 0]])
        for n in normals:
            pa, pb = a @ n, b @ n
            if pa.max() <= pb.min() + 1e-6 or pb.max() <= pa.min() + 1e-6:
                return False
    return True


def point_in_polygon(p: np.ndarray, poly: np.ndarray) -> bool:
    """True when point ``p`` (2,) lies inside the convex counter-clockwise polygon ``poly``."""
    edges = np.roll(poly, -1, axis=0) - poly
    rel = np.asarray(p, dtype=float) - poly
    cross = edges[:, 0] * rel[:, 1] - edges[:, 1] * rel[:, 0]
    return bool(np.all(cross >= -1e-9))
