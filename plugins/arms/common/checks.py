"""Checks every target passes before a byte is sent (Showers 2016, first safeguard).

Each raises :class:`armtree.Unreachable` with a message naming the target and
the limit it breaks; a driver turns that into a FAILED handle and sends nothing.
"""

from __future__ import annotations

import numpy as np

from armtree.errors import Unreachable
from armtree.maths.motion.kinematics import KinematicModel


def check_joint_target(model: KinematicModel, q: np.ndarray) -> np.ndarray:
    """Return ``q`` (degrees / mm) as floats if it is finite, within limits and constraints."""
    try:
        q = np.asarray(q, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise Unreachable(f"{model.name}: joint target {q!r} is not a list of numbers") from exc
    if q.shape != (model.dof,):
        raise Unreachable(
            f"{model.name}: joint target {q.tolist()} has {q.size} values, the arm has {model.dof} joints"
        )
    if not np.all(np.isfinite(q)):
        raise Unreachable(f"{model.name}: joint target {q.tolist()} is not finite")
    for joint, value in zip(model.joints, q, strict=True):
        if not joint.lower - 1e-9 <= value <= joint.upper + 1e-9:
            raise Unreachable(
                f"{model.name}: joint target {np.round(q, 3).tolist()}: {joint.name} = "
                f"{value:.3f} {joint.unit} is outside [{joint.lower:g}, {joint.upper:g}]"
            )
    for c in model.constraints:
        if float(np.asarray(c.g(q))) > 1e-9:
            raise Unreachable(
                f"{model.name}: joint target {np.round(q, 3).tolist()} breaks {c.name} ({c.expr})"
            )
    return q


def check_position_target(
    model: KinematicModel, xyz: np.ndarray, near: np.ndarray | None = None
) -> np.ndarray:
    """Return the joint solution (nearest to ``near``) for tool position ``xyz`` (mm)."""
    try:
        xyz = np.asarray(xyz, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise Unreachable(f"{model.name}: position target {xyz!r} is not three numbers") from exc
    if xyz.shape != (3,):
        raise Unreachable(f"{model.name}: position target {xyz.tolist()} is not x, y, z in mm")
    if not np.all(np.isfinite(xyz)):
        raise Unreachable(f"{model.name}: position target {xyz.tolist()} is not finite")
    q = model.ik(xyz, near=near)
    return check_joint_target(model, q)
