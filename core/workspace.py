"""Workspace approximation by box covering (seed 003), and each arm's reachable workspace.

:func:`cover` is seed 003's non-uniform covering method for a system
``g_j(x) <= 0`` on a starting box P (eq. 4): a box is *outside* when some
``g_j > 0`` on all of it (eq. 7), *inside* when every ``g_j <= 0`` on all of it
(eq. 8), and *boundary* when neither holds and its diameter is at most delta
(eq. 9); any other box is halved along its longest edge. The bounds of each
``g_j`` over a box (eq. 11) come from :mod:`armtree.interval`. armtree runs the
method level by level: all boxes of one level are evaluated in one batch.

:class:`ArmWorkspace` applies it to an arm: the set of tool positions (mm)
reachable within the joint limits and coupled constraints, with a fast exact
:meth:`ArmWorkspace.reachable` test for refusing targets early.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import interval as iv
from .errors import ConfigError
from .interval import Interval
from .kinematics import KinematicModel

#: A constraint system: ``x`` (an Interval or an array, last axis = coordinates)
#: -> the values of every ``g_j``.
ConstraintSystem = Callable[[Any], Sequence[Any]]


@dataclass
class Covering:
    """The result of :func:`cover`: boxes as ``(N, d)`` lower and upper corners.

    ``inner`` boxes lie inside the solution set; ``boundary`` boxes are undecided
    boxes of diameter at most ``delta``. Their union contains the set (seed 003,
    eq. 10). ``outer_count`` boxes were proved outside; ``levels`` is the depth
    of the bisection.
    """

    inner_lo: np.ndarray
    inner_hi: np.ndarray
    boundary_lo: np.ndarray
    boundary_hi: np.ndarray
    outer_count: int
    delta: float
    levels: int

    @staticmethod
    def _measure(lo: np.ndarray, hi: np.ndarray) -> float:
        return float(np.prod(hi - lo, axis=1).sum()) if len(lo) else 0.0

    @property
    def inner_measure(self) -> float:
        """Total area / volume of the inner boxes (mm^d)."""
        return self._measure(self.inner_lo, self.inner_hi)

    @property
    def boundary_measure(self) -> float:
        """Total area / volume of the boundary boxes."""
        return self._measure(self.boundary_lo, self.boundary_hi)

    @property
    def counts(self) -> dict[str, int]:
        """Number of inner, boundary and outer boxes."""
        return {
            "inner": len(self.inner_lo),
            "boundary": len(self.boundary_lo),
            "outer": self.outer_count,
        }


def _as_system(constraints: ConstraintSystem | Sequence[Callable[[Any], Any]]) -> ConstraintSystem:
    if callable(constraints):
        return constraints
    funcs = list(constraints)
    return lambda x: [g(x) for g in funcs]


def cover(
    constraints: ConstraintSystem | Sequence[Callable[[Any], Any]],
    lower: Sequence[float],
    upper: Sequence[float],
    delta: float,
    max_boxes: int = 20_000_000,
) -> Covering:
    """Seed 003's covering of ``{x in [lower, upper] : g_j(x) <= 0 for all j}`` to diameter ``delta``.

    ``constraints`` is a function of an :class:`~armtree.interval.Interval` ``x``
    whose last axis holds the coordinates (``x[..., 0]`` ...) returning the
    ``g_j`` as intervals, or a list of such functions, one per ``g_j``.
    Raises ValueError if more than ``max_boxes`` boxes would be live at once.
    """
    system = _as_system(constraints)
    lo = np.asarray(lower, dtype=float)[None].copy()
    hi = np.asarray(upper, dtype=float)[None].copy()
    if lo.shape != hi.shape or np.any(~(hi > lo)) or not delta > 0:
        raise ValueError(f"need lower < upper and delta > 0, got {lower}, {upper}, {delta}")
    d2 = float(delta) ** 2
    inner_lo, inner_hi, bnd_lo, bnd_hi = [], [], [], []
    outer, levels = 0, 0
    while len(lo):
        levels += 1
        box = Interval(lo, hi)
        out = np.zeros(len(lo), dtype=bool)
        ins = np.ones(len(lo), dtype=bool)
        for g in system(box):
            g = iv.as_interval(g)
            out |= g.lo > 0  # eq. 7
            ins &= g.hi <= 0  # eq. 8
        ins &= ~out
        size = hi - lo
        small = np.einsum("ij,ij->i", size, size) <= d2  # eq. 9, diameter of the box
        und = ~ins & ~out
        bnd = und & small
        inner_lo.append(lo[ins])
        inner_hi.append(hi[ins])
        bnd_lo.append(lo[bnd])
        bnd_hi.append(hi[bnd])
        outer += int(out.sum())
        split = und & ~small
        lo, hi, size = lo[split], hi[split], size[split]
        if 2 * len(lo) > max_boxes:
            raise ValueError(f"covering needs more than {max_boxes} live boxes; raise delta")
        axis = np.argmax(size, axis=1)
        rows = np.arange(len(lo))
        mid = lo[rows, axis] + 0.5 * size[rows, axis]
        hi_left = hi.copy()
        hi_left[rows, axis] = mid
        lo_right = lo.copy()
        lo_right[rows, axis] = mid
        lo, hi = np.concatenate([lo, lo_right]), np.concatenate([hi_left, hi])
    dim = len(lower)

    def cat(parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate(parts) if parts else np.zeros((0, dim))

    return Covering(
        cat(inner_lo), cat(inner_hi), cat(bnd_lo), cat(bnd_hi), outer, float(delta), levels
    )


def satisfied(
    constraints: ConstraintSystem | Sequence[Callable[[Any], Any]], x: np.ndarray, tol: float = 0.0
) -> np.ndarray:
    """Boolean ``(...)``: every ``g_j(x) <= tol`` at points ``x`` ``(..., d)``."""
    x = np.asarray(x, dtype=float)
    ok = np.ones(x.shape[:-1], dtype=bool)
    for g in _as_system(constraints)(x):
        ok &= np.asarray(g) <= tol
    return ok & np.all(np.isfinite(x), axis=-1)


# ---------------------------------------------------------------------------
# Arms
# ---------------------------------------------------------------------------


def sector_constraint(lower_deg: float, upper_deg: float) -> Callable[[Any], Any] | None:
    """``g(x) <= 0`` for points whose azimuth atan2(y, x) lies in ``[lower, upper]`` degrees.

    Written with half-planes instead of atan2 so interval bounds stay tight and no
    box is left undecided along the branch cut. None when the range is a full turn.
    """
    width = upper_deg - lower_deg
    if width >= 360.0:
        return None
    a, b = np.radians(lower_deg), np.radians(upper_deg)
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)

    def g(p: Any) -> Any:
        x, y = p[..., 0], p[..., 1]
        left_of_a = sa * x - ca * y  # <= 0 when p is counter-clockwise of the lower ray
        right_of_b = cb * y - sb * x  # <= 0 when p is clockwise of the upper ray
        return (
            iv.maximum(left_of_a, right_of_b)
            if width <= 180.0
            else iv.minimum(left_of_a, right_of_b)
        )

    return g


def dobot_constraints(
    l1: float,
    l2: float,
    d: float,
    lower: Sequence[float],
    upper: Sequence[float],
    coupled: Sequence[Callable[[Any], Any]] = (),
) -> ConstraintSystem:
    """Reachability of a Dobot-style arm (seed 004 geometry) as ``g_j(x, y, z) <= 0``, mm.

    The inverse kinematics of seed 004 (eqs. 8-10) written in interval-friendly
    operations: theta1 = 90 deg - phi - alpha, theta2 = 180 deg - phi - alpha -
    gamma for the elbow-up branch (and the elbow-down branch too, the union of
    both), each held to the joint limits ``lower``/``upper`` (deg) and to the
    ``coupled`` constraints ``c(q_deg) <= 0`` (seed 004, eq. 4).
    """
    sector = sector_constraint(lower[0], upper[0])
    deg = 180.0 / np.pi

    def branch(theta: list[Any], q0: Any) -> Any:
        g = None
        for k, t in ((1, theta[0]), (2, theta[1])):
            for val in (lower[k] - t, t - upper[k]):
                g = val if g is None else iv.maximum(g, val)
        if coupled:
            if isinstance(theta[0], Interval):
                q = Interval(
                    np.stack([q0.lo, theta[0].lo, theta[1].lo], axis=-1),
                    np.stack([q0.hi, theta[0].hi, theta[1].hi], axis=-1),
                )
            else:
                q = np.stack([q0, theta[0], theta[1]], axis=-1)
            for c in coupled:
                g = iv.maximum(g, c(q))
        return g

    def system(p: Any) -> list[Any]:
        x, y, z = p[..., 0], p[..., 1], p[..., 2]
        rw = iv.hypot(x, y) - d  # seed 004, eq. 8
        rho2 = rw**2 + z**2
        rho = iv.sqrt(rho2)
        gs = [rho2 - (l1 + l2) ** 2, (l1 - l2) ** 2 - rho2]
        alpha = iv.acos((l1**2 - l2**2 + rho2) / (2 * l1 * rho))  # eq. 9
        gamma = iv.acos((l1**2 + l2**2 - rho2) / (2 * l1 * l2))
        phi = iv.atan2(z, rw)
        # theta0 only enters the coupled constraints through q0; its range is the sector test.
        q0 = (
            Interval(np.zeros(np.shape(rw.lo)))
            if isinstance(rw, Interval)
            else np.zeros(np.shape(rw))
        )
        up = [(np.pi / 2 - phi - alpha) * deg, (np.pi - phi - alpha - gamma) * deg]  # eq. 10
        down = [(np.pi / 2 - phi + alpha) * deg, (gamma - np.pi - phi + alpha) * deg]
        gs.append(iv.minimum(branch(up, q0), branch(down, q0)))
        if sector is not None:
            gs.append(sector(p))
        return gs

    return system


def _dobot_bounds(l1: float, l2: float, d: float) -> tuple[np.ndarray, np.ndarray]:
    reach = l1 + l2 + d
    return np.array([-reach, -reach, -(l1 + l2)]), np.array([reach, reach, l1 + l2])


class ArmWorkspace:
    """The reachable tool positions of an arm (mm), from its joint limits and constraints.

    The constraint system comes from the model's ``workspace_constraints`` and
    ``workspace_bounds()`` when it has them (``g_j(p) <= 0`` for p ``(..., 3)``,
    written with :mod:`armtree.interval` functions), or from seed 004's geometry
    for models with ``l1``, ``l2`` and ``d`` attributes (the Dobot family).
    Other models get an IK-based :meth:`reachable` and no covering.
    """

    def __init__(self, model: KinematicModel) -> None:
        self.model = model
        self.system: ConstraintSystem | None = None
        self.bounds: tuple[np.ndarray, np.ndarray] | None = None
        if hasattr(model, "workspace_constraints"):
            self.system = model.workspace_constraints
            lo, hi = model.workspace_bounds()
            self.bounds = (np.asarray(lo, dtype=float), np.asarray(hi, dtype=float))
        elif all(hasattr(model, a) for a in ("l1", "l2", "d")) and model.dof == 3:
            l1, l2, d = float(model.l1), float(model.l2), float(model.d)
            coupled = [c.g for c in model.constraints]
            self.system = dobot_constraints(l1, l2, d, model.lower, model.upper, coupled)
            lo, hi = _dobot_bounds(l1, l2, d)
            tool = np.asarray(getattr(model, "tool_offset", np.zeros(3)), dtype=float)
            self.bounds = (lo - np.abs(tool), hi + np.abs(tool))

    @property
    def has_covering(self) -> bool:
        """True when the arm's workspace is described by constraints (so it can be covered)."""
        return self.system is not None

    def cover(self, delta: float, max_boxes: int = 20_000_000) -> Covering:
        """Seed 003's covering of the reachable workspace to box diameter ``delta`` mm."""
        if self.system is None or self.bounds is None:
            raise ConfigError(
                f"arm model {self.model.name!r} does not describe its workspace as constraints "
                "(workspace_constraints / workspace_bounds), so it cannot be covered"
            )
        return cover(self.system, self.bounds[0], self.bounds[1], delta, max_boxes)

    def reachable(self, xyz: np.ndarray, tol: float = 1e-6) -> np.ndarray | bool:
        """Exact test: can the tool reach ``xyz`` ``(..., 3)`` mm within the limits?

        Evaluates the constraints at the points (microseconds for thousands of
        points), or for models without them asks the inverse kinematics.
        """
        p = np.asarray(xyz, dtype=float)
        if self.system is not None:
            ok = satisfied(self.system, p, tol)
        else:
            finite = np.all(np.isfinite(p), axis=-1)
            safe = np.where(finite[..., None], p, 0.0)
            sols = self.model.ik_all(safe)
            ok = finite & np.any(np.all(np.isfinite(sols), axis=-1), axis=-1)
        return bool(ok) if p.ndim == 1 else ok
