"""Where calibrations and experiments put the tool: reachable, and where the camera sees it.

Everything here asks the arm's model and the camera's believed pose and view
(never the simulator): a position counts when the arm reaches it within its
limits and, eye-to-hand, when the tool's marker projects inside the image with
a margin. Positions are the tool centre, mm in the base frame.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from armtree.maths.motion.kinematics import KinematicModel

#: Fraction of the half image a marker may use (its centre stays this far in from the edge).
VIEW_MARGIN = 0.8


def in_view(
    camera_pose: np.ndarray,
    half_view: tuple[float, float],
    points: np.ndarray,
    margin: float = VIEW_MARGIN,
) -> np.ndarray:
    """Boolean per point ``(N, 3)``: in front of the camera and within ``margin`` of the half image."""
    cam_T_base = np.linalg.inv(np.asarray(camera_pose, dtype=float))
    p = np.asarray(points, dtype=float) @ cam_T_base[:3, :3].T + cam_T_base[:3, 3]
    z = p[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        ok = (
            (z > 50.0)
            & (np.abs(p[:, 0] / z) < margin * half_view[0])
            & (np.abs(p[:, 1] / z) < margin * half_view[1])
        )
    return ok


def reachable_mask(model: KinematicModel, points: np.ndarray) -> np.ndarray:
    """Boolean per point: some inverse-kinematics solution within the limits."""
    sols = model.ik_all(np.asarray(points, dtype=float))
    return np.any(np.all(np.isfinite(sols), axis=-1), axis=-1)


def workspace_samples(
    model: KinematicModel, rng: np.random.Generator, count: int = 4000, min_z: float | None = None
) -> np.ndarray:
    """Tool positions ``(N, 3)`` of random joints within the limits (and at least ``min_z``)."""
    q = rng.uniform(model.lower, model.upper, (count, model.dof))
    q = q[model.within_limits(q)]
    points = model.position(q)
    if min_z is not None:
        points = points[points[:, 2] >= min_z]
    return points


def spread(points: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` of ``points`` as far apart as can be (farthest-point sampling)."""
    points = np.asarray(points, dtype=float)
    if len(points) <= count:
        return points
    chosen = [int(rng.integers(len(points)))]
    distance = np.linalg.norm(points - points[chosen[0]], axis=1)
    for _ in range(count - 1):
        chosen.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.linalg.norm(points - points[chosen[-1]], axis=1))
    return points[chosen]


def square_grid(
    model: KinematicModel,
    height: float,
    n: int,
    usable: Callable[[np.ndarray], np.ndarray],
    centre: np.ndarray | None = None,
) -> np.ndarray:
    """An ``n`` x ``n`` square grid at ``height`` (mm) of the largest side that keeps every
    point in ``usable`` (a predicate on ``(N, 3)`` points), centred where the most room is.

    ``usable`` already includes reachability. Raises ValueError when no grid of at
    least 1 mm spacing fits.
    """
    samples = np.asarray(centre, dtype=float).reshape(-1, 3) if centre is not None else None
    if samples is None:
        rng = np.random.default_rng(0)
        pts = workspace_samples(model, rng, 6000)
        pts[:, 2] = height
        pts = pts[usable(pts)]
        if not len(pts):
            raise ValueError(f"nothing at z = {height:g} mm is reachable and in view")
        samples = spread(pts, 40, rng)
    best: np.ndarray | None = None
    best_side = 0.0
    unit = np.linspace(-0.5, 0.5, n)
    gx, gy = np.meshgrid(unit, unit, indexing="ij")
    offsets = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)])
    for c in samples:
        lo, hi = 0.0, 1000.0
        while hi - lo > 0.5:
            side = 0.5 * (lo + hi)
            grid = np.array([c[0], c[1], height]) + offsets * side
            if np.all(usable(grid)):
                lo = side
            else:
                hi = side
        if lo > best_side:
            best_side, best = lo, np.array([c[0], c[1], height]) + offsets * lo
    if best is None or best_side < (n - 1) * 1.0:
        raise ValueError(
            f"no {n} x {n} grid at z = {height:g} mm fits where the arm reaches and the camera sees"
        )
    return best


__all__ = ["VIEW_MARGIN", "in_view", "reachable_mask", "spread", "square_grid", "workspace_samples"]
