"""Rigid transforms and box geometry, batched over leading axes.

Angles are in degrees at the public edges (``rot_*_deg``, ``from_rpy_deg``) and in
radians inside (``rot_*``). Lengths are in millimetres. Every function accepts
arrays with any leading shape and keeps it.
"""

from __future__ import annotations

import numpy as np

#: The 8 corner signs of a unit box, ``(8, 3)``; corner ``k`` has bits (x, y, z) of ``k``.
BOX_CORNER_SIGNS = (
    np.array([[(k >> 0) & 1, (k >> 1) & 1, (k >> 2) & 1] for k in range(8)], dtype=float) * 2.0
    - 1.0
)

#: The 12 triangles of a box as corner indices into :data:`BOX_CORNER_SIGNS`, outward-facing.
BOX_TRIANGLES = np.array(
    [
        [0, 2, 1], [1, 2, 3],  # -z
        [4, 5, 6], [5, 7, 6],  # +z
        [0, 1, 4], [1, 5, 4],  # -y
        [2, 6, 3], [3, 6, 7],  # +y
        [0, 4, 2], [2, 4, 6],  # -x
        [1, 3, 5], [3, 7, 5],  # +x
    ],
    dtype=np.intp,
)  # fmt: skip


def rot_x(a: np.ndarray | float) -> np.ndarray:
    """Rotation about x by ``a`` radians, ``(..., 3, 3)``."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([o, z, z, z, c, -s, z, s, c], axis=-1).reshape(a.shape + (3, 3))


def rot_y(a: np.ndarray | float) -> np.ndarray:
    """Rotation about y by ``a`` radians, ``(..., 3, 3)``."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([c, z, s, z, o, z, -s, z, c], axis=-1).reshape(a.shape + (3, 3))


def rot_z(a: np.ndarray | float) -> np.ndarray:
    """Rotation about z by ``a`` radians, ``(..., 3, 3)``."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([c, -s, z, s, c, z, z, z, o], axis=-1).reshape(a.shape + (3, 3))


def from_rpy_deg(rpy: np.ndarray) -> np.ndarray:
    """Rotation ``Rz(yaw) Ry(pitch) Rx(roll)`` from ``(..., 3)`` roll, pitch, yaw in degrees."""
    r = np.radians(np.asarray(rpy, dtype=float))
    return rot_z(r[..., 2]) @ rot_y(r[..., 1]) @ rot_x(r[..., 0])


def transform(
    rotation: np.ndarray | None = None, translation: np.ndarray | None = None
) -> np.ndarray:
    """A 4x4 homogeneous transform (batched) from a rotation and a translation in mm."""
    rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    trans = np.zeros(3) if translation is None else np.asarray(translation, dtype=float)
    shape = np.broadcast_shapes(rot.shape[:-2], trans.shape[:-1])
    out = np.zeros(shape + (4, 4))
    out[..., :3, :3] = rot
    out[..., :3, 3] = trans
    out[..., 3, 3] = 1.0
    return out


def invert(t: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms ``(..., 4, 4)`` (rotation transposed, no general inverse)."""
    t = np.asarray(t, dtype=float)
    rt = np.swapaxes(t[..., :3, :3], -1, -2)
    return transform(rt, -(rt @ t[..., :3, 3:])[..., 0])


def apply(t: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Transform points ``(..., P, 3)`` by ``t`` ``(..., 4, 4)`` (broadcast on leading axes)."""
    t = np.asarray(t, dtype=float)
    return points @ np.swapaxes(t[..., :3, :3], -1, -2) + t[..., None, :3, 3]


def box_corners(poses: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """Corners ``(..., 8, 3)`` of boxes with centre poses ``(..., 4, 4)`` and sizes ``(..., 3)``."""
    half = 0.5 * np.asarray(sizes, dtype=float)
    local = BOX_CORNER_SIGNS * half[..., None, :]
    return apply(poses, local)


def box_triangles(poses: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """The 12 surface triangles ``(..., 12, 3, 3)`` of boxes (see :func:`box_corners`)."""
    return box_corners(poses, sizes)[..., BOX_TRIANGLES, :]
