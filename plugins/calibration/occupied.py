"""What stands on the table, as a calibration may know it: what the camera sees and
what the profile declares.

A calibration or an experiment that draws its own points (targets on the table,
poses for the tool) must not put them under or into things. It knows two kinds
of them: the markers a fixed camera sees in an overview (each one on top of an
object; the marker's position gives the object's place and top) and the
profile's ``obstacles`` (the planner's collision scene). Each becomes a
:class:`KeepOut`: a vertical cylinder the tool's point stays out of below its
top. mm, base frame.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class KeepOut:
    """A disc of ``radius`` mm around ``xy`` on the table, occupied up to ``top_z`` mm."""

    name: str
    xy: np.ndarray
    radius: float
    top_z: float


def seen_keep_outs(
    sightings: Iterable[Any], skip_roles: Iterable[str], radius: float
) -> list[KeepOut]:
    """A keep-out of ``radius`` mm around every marker seen (its top at the marker's height),
    except those of ``skip_roles`` (the target's own, the tool's)."""
    skip = set(skip_roles)
    out = []
    for s in sightings:
        if s.role in skip:
            continue
        p = np.asarray(s.position, dtype=float)
        out.append(KeepOut(f"{s.role} marker {s.id}", p[:2].copy(), float(radius), float(p[2])))
    return out


def declared_keep_outs(scene: Any, margin: float = 0.0) -> list[KeepOut]:
    """The profile's obstacles (a :class:`~armtree.maths.motion.scene.Scene`) as keep-outs: each
    box's or mesh's footprint enclosed in a disc grown by ``margin`` mm."""
    out = []
    for box in getattr(scene, "boxes", ()):
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        pts = box.center + (corners * 0.5 * box.size) @ box.rotation.T
        out.append(_enclosing(box.name, pts, margin))
    for mesh in getattr(scene, "meshes", ()):
        out.append(_enclosing(mesh.name, mesh.triangles.reshape(-1, 3), margin))
    return out


def _enclosing(name: str, points: np.ndarray, margin: float) -> KeepOut:
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = 0.5 * (lo[:2] + hi[:2])
    radius = float(np.max(np.linalg.norm(points[:, :2] - centre, axis=1))) + margin
    return KeepOut(name, centre, radius, float(hi[2]))


def free(points: np.ndarray, keep_outs: Iterable[KeepOut], clearance: float = 0.0) -> np.ndarray:
    """Boolean per point ``(N, 3)``: outside every keep-out's disc, or at least ``clearance``
    mm above its top."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    ok = np.ones(len(points), dtype=bool)
    for k in keep_outs:
        away = np.linalg.norm(points[:, :2] - k.xy, axis=1) >= k.radius
        ok &= away | (points[:, 2] >= k.top_z + clearance)
    return ok


def blocker(point: np.ndarray, keep_outs: Iterable[KeepOut], clearance: float = 0.0) -> str:
    """The name of the first keep-out ``point`` is in ('' for none), for messages."""
    for k in keep_outs:
        if not free(point, [k], clearance)[0]:
            return k.name
    return ""


__all__ = ["KeepOut", "blocker", "declared_keep_outs", "free", "seen_keep_outs"]
