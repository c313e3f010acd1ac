"""How deep a configuration's contacts go: a signed depth (mm) for each contact.

The :class:`~armtree.maths.motion.collision.CollisionChecker` only says *whether* a link
box collides; this module says *how deep*, for the rare configuration that does
(a believed start left in contact by a slipped joint). A link box against the
table plane is exact: how far its lowest corner lies below the plane. A link
box against an obstacle box, a mesh triangle or another link box is a pair of
convex polyhedra, and the separating-axis theorem gives the depth: the smallest
overlap of their projections over the face normals and the edge-edge cross
products, which is how far one must move to clear the other. A mesh's depth is
its deepest triangle's. Depths are signed: negative is a gap along the best axis
(a lower bound of the distance), so they vary smoothly as a contact opens.
Link boxes keep the checker's margin.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .collision import TOUCH_TOL, CollisionChecker, Contact
from .geometry import BOX_CORNER_SIGNS

#: The deepest start contact (mm) a planner steps out of; a deeper one is refused.
START_CONTACT_MM = 5.0

#: A contact's identity across configurations: (kind, link box index, what it hits).
#: ``kind`` is ``table``, ``box`` (an obstacle box), ``mesh`` or ``self`` (another link box).
ContactKey = tuple[str, int, int]


class Penetration(NamedTuple):
    """One contact of a configuration and how deep it goes (mm, > 0)."""

    #: Which pair it is (:data:`ContactKey`), to measure it again at another configuration.
    key: ContactKey
    contact: Contact
    depth_mm: float

    def record(self) -> dict:
        """JSON-safe fields for the run log."""
        return {
            "link": self.contact.box,
            "other": self.contact.other,
            "depth_mm": round(self.depth_mm, 4),
        }

    def __str__(self) -> str:
        return f"{self.contact} {self.depth_mm:.2f} mm deep"


def penetrations(checker: CollisionChecker, q: np.ndarray) -> list[Penetration]:
    """Every contact of configuration ``q`` (deg / mm) deeper than the touching tolerance."""
    keys = candidate_keys(checker)
    depth = signed_depths(checker, q, keys)
    return [
        Penetration(k, _contact(checker, k), float(d))
        for k, d in zip(keys, depth, strict=True)
        if d > TOUCH_TOL
    ]


def candidate_keys(checker: CollisionChecker) -> list[ContactKey]:
    """Every pair the checker looks at: each moving link box against the table, each
    obstacle box, each mesh, and the link-box pairs it checks for self-collision."""
    scene = checker.scene
    keys: list[ContactKey] = []
    for b in checker.moving.tolist():
        if scene.table_z is not None:
            keys.append(("table", b, -1))
        keys += [("box", b, o) for o in range(len(scene.boxes))]
        keys += [("mesh", b, m) for m in range(len(scene.meshes))]
    keys += [("self", int(i), int(j)) for i, j in checker.pairs]
    return keys


def signed_depths(checker: CollisionChecker, q: np.ndarray, keys: list[ContactKey]) -> np.ndarray:
    """Signed depth (mm) of each contact ``keys`` at configuration ``q``: > 0 overlapping."""
    poses = checker.model.box_poses(np.asarray(q, dtype=float)[None])[0]
    rot, centre, half = poses[:, :3, :3], poses[:, :3, 3], checker.half
    scene = checker.scene
    out = np.empty(len(keys))
    for n, (kind, b, other) in enumerate(keys):
        if kind == "table":
            if scene.table_z is None:
                raise ValueError("a table contact for a scene without a table")
            low = centre[b, 2] - np.abs(rot[b, 2, :]) @ half[b]
            out[n] = float(scene.table_z) - low
        elif kind == "box":
            ob = scene.boxes[other]
            out[n] = box_box_depth(
                rot[b], centre[b], half[b], np.asarray(ob.rotation), ob.center, 0.5 * ob.size
            )
        elif kind == "mesh":
            out[n] = box_triangles_depth(rot[b], centre[b], half[b], scene.meshes[other].triangles)
        else:
            out[n] = box_box_depth(
                rot[b], centre[b], half[b], rot[other], centre[other], half[other]
            )
    return out


def _contact(checker: CollisionChecker, key: ContactKey) -> Contact:
    kind, b, other = key
    name = checker.names[b]
    if kind == "table":
        return Contact(name, "the table")
    if kind == "box":
        return Contact(name, f"obstacle {checker.scene.boxes[other].name!r}")
    if kind == "mesh":
        return Contact(name, f"mesh {checker.scene.meshes[other].name!r}")
    return Contact(name, f"link box {checker.names[other]!r} (self-collision)")


def _corners(rot: np.ndarray, centre: np.ndarray, half: np.ndarray) -> np.ndarray:
    return centre + (BOX_CORNER_SIGNS * half) @ rot.T


def box_box_depth(
    ra: np.ndarray, ca: np.ndarray, ha: np.ndarray, rb: np.ndarray, cb: np.ndarray, hb: np.ndarray
) -> float:
    """Signed depth of two oriented boxes: 3 + 3 face normals and 9 edge-edge axes."""
    crosses = np.cross(ra.T[:, None, :], rb.T[None, :, :]).reshape(9, 3)
    axes = np.vstack([ra.T, rb.T, crosses])
    return float(_sat_depth(_corners(ra, ca, ha), _corners(rb, cb, np.asarray(hb)), axes))


def box_triangles_depth(
    rot: np.ndarray, centre: np.ndarray, half: np.ndarray, tris: np.ndarray
) -> float:
    """Signed depth of a box against its deepest triangle ``tris`` ``(T, 3, 3)``:
    the box's 3 face normals, the triangle's normal and 9 edge-edge axes each."""
    tris = np.asarray(tris, dtype=float)
    edges = np.roll(tris, -1, axis=1) - tris  # (T, 3, 3)
    normal = np.cross(edges[:, 0], edges[:, 1])[:, None]  # (T, 1, 3)
    crosses = np.cross(rot.T[None, :, None, :], edges[:, None, :, :]).reshape(-1, 9, 3)
    axes = np.concatenate([np.broadcast_to(rot.T, (len(tris), 3, 3)), normal, crosses], axis=1)
    corners = np.broadcast_to(_corners(rot, centre, half), (len(tris), 8, 3))
    return float(_sat_depth(corners, tris, axes).max())


def _sat_depth(a: np.ndarray, b: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """Smallest projection overlap (mm) of point sets ``a`` ``(..., P, 3)`` and ``b``
    ``(..., Q, 3)`` over ``axes`` ``(..., K, 3)``; degenerate axes (parallel edges) are skipped."""
    norm = np.linalg.norm(axes, axis=-1)
    usable = norm > 1e-9
    unit = axes / np.where(usable, norm, 1.0)[..., None]
    pa = np.einsum("...pi,...ki->...kp", a, unit)
    pb = np.einsum("...qi,...ki->...kq", b, unit)
    overlap = np.minimum(pa.max(axis=-1) - pb.min(axis=-1), pb.max(axis=-1) - pa.min(axis=-1))
    return np.where(usable, overlap, np.inf).min(axis=-1)


def leaving_run(
    checker: CollisionChecker, samples: np.ndarray, max_depth: float = START_CONTACT_MM
) -> int | None:
    """How many leading ``samples`` ``(N, n)`` are in collision, if they only leave it.

    The first sample's contacts must be at most ``max_depth`` mm deep, and each
    following sample in collision may only keep those contacts, none deeper than
    the sample before; the first free sample ends the run. None when that fails
    or no sample is free.
    """
    q = np.asarray(samples, dtype=float)
    first = penetrations(checker, q[0])
    if not first or max(p.depth_mm for p in first) > max_depth:
        return None
    keys = [p.key for p in first]
    before = np.array([p.depth_mm for p in first])
    for k in range(1, len(q)):
        if not checker.collides(q[k]):
            return k
        now = penetrations(checker, q[k])
        if any(p.key not in keys for p in now):
            return None
        depth = signed_depths(checker, q[k], keys)
        if np.any(depth > before + 1e-9):
            return None
        before = depth
    return None
