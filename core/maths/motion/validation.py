"""Checks of configurations and sampled paths that say why a motion is refused.

Pozzani 2023 (validatePath) refuses a trajectory when a configuration along it
collides or nears a singularity (the Jacobian's smallest singular value near
zero); armtree adds the joint limits and coupled constraints. Joint values are
degrees / mm; singular values are in mm per degree (or mm per mm).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armtree.errors import PlanningError

from .collision import CollisionChecker
from .kinematics import KinematicModel
from .penetration import leaving_run


def smallest_singular_value(model: KinematicModel, q: np.ndarray) -> np.ndarray:
    """Smallest singular value of the positional Jacobian at ``q`` ``(..., n)``, mm/deg."""
    jac = model.jacobian(np.asarray(q, dtype=float))
    return np.linalg.svd(jac, compute_uv=False)[..., -1]


def limit_violations(model: KinematicModel, q: np.ndarray) -> list[str]:
    """Human-readable list of the joint limits and constraints that ``q`` (one config) breaks."""
    q = np.asarray(q, dtype=float)
    out = []
    for k, joint in enumerate(model.joints):
        if not joint.lower - 1e-9 <= q[k] <= joint.upper + 1e-9:
            out.append(
                f"{joint.name} = {q[k]:.2f} {joint.unit} outside [{joint.lower:g}, {joint.upper:g}]"
            )
    for c in model.constraints:
        if float(np.asarray(c.g(q))) > 1e-9:
            out.append(f"constraint {c.name} ({c.expr}) violated")
    return out


def check_config(
    checker: CollisionChecker, q: np.ndarray, role: str, min_singular: float | None = None
) -> np.ndarray:
    """Return ``q`` as a float array, or raise PlanningError naming why it cannot be used.

    Reasons: ``not_finite``, ``outside_limits``, ``{role}_in_collision``, ``singular``.
    """
    model = checker.model
    q = np.asarray(q, dtype=float)
    if q.shape != (model.dof,):
        raise PlanningError(
            f"{role} must have {model.dof} joint values, got shape {q.shape}", reason="bad_shape"
        )
    if not np.all(np.isfinite(q)):
        raise PlanningError(f"{role} {q.tolist()} is not finite", reason="not_finite")
    broken = limit_violations(model, q)
    if broken:
        raise PlanningError(
            f"{role} {np.round(q, 2).tolist()} is outside the limits: " + "; ".join(broken),
            reason="outside_limits",
        )
    contacts = checker.contacts(q)
    if contacts:
        raise PlanningError(
            f"{role} {np.round(q, 2).tolist()} is in collision: " + "; ".join(map(str, contacts)),
            reason=f"{role}_in_collision",
        )
    if min_singular is not None:
        sv = float(smallest_singular_value(model, q))
        if sv < min_singular:
            raise PlanningError(
                f"{role} {np.round(q, 2).tolist()} is near a singularity "
                f"(smallest singular value {sv:.3g} < {min_singular:g} mm/deg)",
                reason="singular",
            )
    return q


@dataclass(frozen=True)
class PathReport:
    """The verdict on a sampled path: ``ok``, or the first bad sample's ``index`` and ``reason``."""

    ok: bool
    reason: str = ""
    index: int = -1
    message: str = ""

    def raise_if_bad(self) -> None:
        """Raise :class:`PlanningError` with the reason when the path is not ok."""
        if not self.ok:
            raise PlanningError(self.message, reason=self.reason)


def validate_samples(
    checker: CollisionChecker,
    samples: np.ndarray,
    min_singular: float | None = None,
    times: np.ndarray | None = None,
    start_contact_mm: float = 0.0,
) -> PathReport:
    """Check configurations ``(N, n)`` along a path, in order, all in one batch.

    Reports the first sample that is non-finite, outside the limits, colliding,
    or (with ``min_singular``) whose Jacobian's smallest singular value is below
    it (Pozzani 2023, validatePath). ``times`` (s) only label the message. With
    ``start_contact_mm`` > 0 the first sample is where the arm is, and a path may
    begin in a contact at most that deep (mm) if it only leaves it
    (:func:`~armtree.maths.motion.penetration.leaving_run`).
    """
    model = checker.model
    q = np.asarray(samples, dtype=float).reshape(-1, model.dof)

    def where(i: int) -> str:
        at = f" at t = {times[i]:.3f} s" if times is not None else f" at sample {i}"
        return f"{at} (q = {np.round(q[i], 2).tolist()})"

    finite = np.all(np.isfinite(q), axis=1)
    if not finite.all():
        i = int(np.argmin(finite))
        return PathReport(False, "not_finite", i, f"path is not finite{where(i)}")
    inside = np.asarray(model.within_limits(q)).reshape(-1)
    if not inside.all():
        i = int(np.argmin(inside))
        return PathReport(
            False,
            "outside_limits",
            i,
            f"path leaves the limits{where(i)}: " + "; ".join(limit_violations(model, q[i])),
        )
    hit = np.asarray(checker.collides(q)).reshape(-1)
    if hit[:1].any() and start_contact_mm > 0:
        run = leaving_run(checker, q, start_contact_mm)
        if run is not None:
            hit = hit.copy()
            hit[:run] = False
    if hit.any():
        i = int(np.argmax(hit))
        return PathReport(
            False,
            "collision",
            i,
            f"path collides{where(i)}: " + "; ".join(map(str, checker.contacts(q[i]))),
        )
    if min_singular is not None:
        sv = smallest_singular_value(model, q)
        low = sv < min_singular
        if low.any():
            i = int(np.argmax(low))
            return PathReport(
                False,
                "singular",
                i,
                f"path passes near a singularity{where(i)}: smallest singular value "
                f"{sv[i]:.3g} < {min_singular:g} mm/deg",
            )
    return PathReport(True)
