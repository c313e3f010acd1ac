"""Choosing reachable tool positions near wanted ones, for arms with small workspaces.

A tree says "approach 60 mm above" or "scan at 120 mm"; a Dobot V1.0 within
Showers 2016's conservative joint limits reaches only a few centimetres of height,
so a skill asks here for the closest position the arm's model can reach
instead of failing. Everything is a batched inverse-kinematics query on the
rig's :class:`~armtree.maths.motion.kinematics.KinematicModel`; positions in mm.
"""

from __future__ import annotations

import numpy as np

from armtree.maths.motion.kinematics import KinematicModel


def reachable(model: KinematicModel, points: np.ndarray) -> np.ndarray:
    """Boolean ``(...)``: whether some IK solution within the limits reaches each point."""
    sols = model.ik_all(np.asarray(points, dtype=float))
    # array methods: skills ask this hundreds of times a run, mostly of one point
    return np.isfinite(sols).all(axis=-1).any(axis=-1)


def highest_reachable(
    model: KinematicModel, point: np.ndarray, low: float, high: float, step: float = 1.0
) -> np.ndarray | None:
    """The point at ``point``'s x, y with the highest reachable z in [low, high], or None."""
    zs = np.arange(high, low - 1e-9, -abs(step)) if high > low else np.array([low])
    return _first_reachable(model, point, zs)


def lowest_reachable(
    model: KinematicModel, point: np.ndarray, low: float, high: float, step: float = 0.5
) -> np.ndarray | None:
    """The point at ``point``'s x, y with the lowest reachable z in [low, high], or None."""
    zs = np.arange(low, high + 1e-9, abs(step)) if high > low else np.array([low])
    return _first_reachable(model, point, zs)


def _first_reachable(model: KinematicModel, point: np.ndarray, zs: np.ndarray) -> np.ndarray | None:
    p = np.asarray(point, dtype=float).reshape(3)
    cands = np.repeat(p[None, :], len(zs), axis=0)
    cands[:, 2] = zs
    ok = reachable(model, cands)
    if not ok.any():
        return None
    return cands[int(np.argmax(ok))]


def nearest_reachable(
    model: KinematicModel,
    target: np.ndarray,
    span: float = 150.0,
    step: float = 1.0,
    min_z: float | None = None,
) -> np.ndarray | None:
    """The reachable point closest to ``target`` in the vertical plane through it and the base z-axis.

    Searches reach and height within ``span`` mm of the target's, coarse to fine
    down to ``step`` mm, at heights of at least ``min_z`` when given; None when
    nothing there is reachable.
    """
    t = np.asarray(target, dtype=float).reshape(3)
    if (min_z is None or t[2] >= min_z) and reachable(model, t):
        return t
    r0 = float(np.hypot(t[0], t[1]))
    angle = np.arctan2(t[1], t[0]) if r0 > 1e-9 else 0.0
    center = np.array([r0, t[2]])
    best: np.ndarray | None = None
    coarse = max(step, span / 15.0)
    cos, sin = np.cos(angle), np.sin(angle)
    for grid, half in ((coarse, span), (step, coarse * 1.5)):
        offsets = np.arange(-half, half + 1e-9, grid)
        rr, zz = np.meshgrid(center[0] + offsets, center[1] + offsets, indexing="ij")
        rr = np.maximum(rr, 0.0)
        cands = np.stack([rr * cos, rr * sin, zz], axis=-1).reshape(-1, 3)
        if min_z is not None:
            cands = cands[cands[:, 2] >= min_z - 1e-9]
        ok = reachable(model, cands) if len(cands) else np.zeros(0, dtype=bool)
        if not ok.any():
            if best is None:
                return None
            break
        cands = cands[ok]
        found = cands[int(np.argmin(np.linalg.norm(cands - t, axis=-1)))]
        if best is None or np.linalg.norm(found - t) < np.linalg.norm(best - t):
            best = found
        center = np.array([np.hypot(best[0], best[1]), best[2]])
    return best
