"""Workspace approximation by box covering (Rybak 2016), and an arm's reachable workspace.

:func:`cover` is Rybak 2016's non-uniform covering method for a system
``g_j(x) <= 0`` on a starting box P (eq. 4): a box is *outside* when some
``g_j > 0`` on all of it (eq. 7), *inside* when every ``g_j <= 0`` on all of it
(eq. 8), and *boundary* when neither holds and its diameter is at most delta
(eq. 9); any other box is halved along its longest edge. The bounds of each
``g_j`` over a box (eq. 11) come from :mod:`armtree.maths.motion.interval`. armtree runs the
method level by level: all boxes of one level are evaluated in one batch.

:class:`ArmWorkspace` applies it to an arm: the set of tool positions (mm)
reachable within the joint limits and coupled constraints, as the arm plugin's
kinematic model describes it (:class:`WorkspaceShape`; each arm's geometry
lives with its plugin), with a fast exact :meth:`ArmWorkspace.reachable` test
for refusing targets early.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from armtree.errors import ConfigError, Unreachable

from . import interval as iv
from .interval import Interval
from .kinematics import KinematicModel

#: A constraint system: ``x`` (an Interval or an array, last axis = coordinates)
#: -> the values of every ``g_j``.
ConstraintSystem = Callable[[Any], Sequence[Any]]


@dataclass
class Covering:
    """The result of :func:`cover`: boxes as ``(N, d)`` lower and upper corners.

    ``inner`` boxes lie inside the solution set; ``boundary`` boxes are undecided
    boxes of diameter at most ``delta``. Their union contains the set (Rybak 2016,
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
    lower: Sequence[float] | NDArray[np.float64],
    upper: Sequence[float] | NDArray[np.float64],
    delta: float,
    max_boxes: int = 20_000_000,
) -> Covering:
    """Rybak 2016's covering of ``{x in [lower, upper] : g_j(x) <= 0 for all j}`` to diameter ``delta``.

    ``constraints`` is a function of an :class:`~armtree.maths.motion.interval.Interval` ``x``
    whose last axis holds the coordinates (``x[..., 0]`` ...) returning the
    ``g_j`` as intervals, or a list of such functions, one per ``g_j``.
    Raises ValueError if more than ``max_boxes`` boxes would be live at once.
    """
    system = _as_system(constraints)
    lo = np.asarray(lower, dtype=float)[None].copy()
    size = np.asarray(upper, dtype=float) - lo[0]
    if size.shape != lo[0].shape or np.any(~(size > 0)) or not delta > 0:
        raise ValueError(f"need lower < upper and delta > 0, got {lower}, {upper}, {delta}")
    d2 = float(delta) ** 2
    # Longest-edge halving from one root box keeps every box of a level the same
    # size, so a level is its lower corners plus one shared size vector.
    inner_lo, inner_hi, bnd_lo, bnd_hi = [], [], [], []
    outer, levels = 0, 0
    while len(lo):
        levels += 1
        out = np.zeros(len(lo), dtype=bool)
        ins = np.ones(len(lo), dtype=bool)
        for g in system(Interval(lo, lo + size)):
            g = iv.as_interval(g)
            out |= g.lo > 0  # eq. 7
            ins &= g.hi <= 0  # eq. 8
        ins &= ~out
        und = ~(ins | out)
        outer += int(np.count_nonzero(out))
        keep = lo[ins]
        inner_lo.append(keep)
        inner_hi.append(keep + size)
        lo = lo[und]
        if float(size @ size) <= d2:  # eq. 9: the diameter of this level's boxes
            bnd_lo.append(lo)
            bnd_hi.append(lo + size)
            break
        if 2 * len(lo) > max_boxes:
            raise ValueError(f"covering needs more than {max_boxes} live boxes; raise delta")
        axis = int(np.argmax(size))
        size = size.copy()
        size[axis] *= 0.5
        n = len(lo)
        lo = np.concatenate([lo, lo])
        lo[n:, axis] += size[axis]
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


def _linear(p: Any, a: float, b: float) -> Any:
    """``a x + b y`` for points, or its exact bounds over boxes (an Interval)."""
    if not isinstance(p, Interval):
        return a * p[..., 0] + b * p[..., 1]
    xl, xh, yl, yh = p.lo[..., 0], p.hi[..., 0], p.lo[..., 1], p.hi[..., 1]
    lo = a * (xl if a >= 0 else xh) + b * (yl if b >= 0 else yh)
    hi = a * (xh if a >= 0 else xl) + b * (yh if b >= 0 else yl)
    return Interval(lo, hi)


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
        left_of_a = _linear(p, sa, -ca)  # <= 0 when p is counter-clockwise of the lower ray
        right_of_b = _linear(p, -sb, cb)  # <= 0 when p is clockwise of the upper ray
        return (
            iv.maximum(left_of_a, right_of_b)
            if width <= 180.0
            else iv.minimum(left_of_a, right_of_b)
        )

    return g


def _joint_vector(
    theta: dict[int, Any],
    lower: Sequence[float] | np.ndarray,
    upper: Sequence[float] | np.ndarray,
    like: Any,
) -> Any:
    """All joints as one ``(..., n)`` value: the given ones, the others over their whole range."""
    n = len(lower)
    interval = isinstance(like, Interval)
    shape = np.shape(like.lo) if interval else np.shape(like)
    lo_cols, hi_cols = [], []
    for k in range(n):
        t = theta.get(k)
        if t is None:
            lo_cols.append(np.full(shape, float(lower[k])))
            hi_cols.append(np.full(shape, float(upper[k])))
        else:
            t = iv.as_interval(t)
            lo_cols.append(np.broadcast_to(t.lo, shape))
            hi_cols.append(np.broadcast_to(t.hi, shape))
    if interval:
        return Interval(np.stack(lo_cols, axis=-1), np.stack(hi_cols, axis=-1))
    # Point evaluation: joints not given are irrelevant to position; use their midpoints.
    return np.stack([0.5 * (a + b) for a, b in zip(lo_cols, hi_cols, strict=True)], axis=-1)


def limits_constraint(
    theta: dict[int, Any],
    lower: Sequence[float] | np.ndarray,
    upper: Sequence[float] | np.ndarray,
    coupled: Sequence[Callable[[Any], Any]],
    like: Any,
) -> Any:
    """``max`` of every limit ``lower - t <= 0``, ``t - upper <= 0`` and coupled constraint.

    ``theta`` maps joint indices to their values (points or Intervals, degrees);
    joints not given span their whole range in the ``coupled`` constraints.
    """
    g = None
    for k, t in theta.items():
        for val in (lower[k] - t, t - upper[k]):
            g = val if g is None else iv.maximum(g, val)
    if coupled:
        q = _joint_vector(theta, lower, upper, like)
        for c in coupled:
            g = iv.maximum(g, _bound(c, q))
    return g


def _bound(c: Callable[[Any], Any], q: Any) -> Any:
    """``c(q)`` for points, or its bounds over the joint boxes ``q`` (an Interval).

    A constraint written with plain numpy cannot take an Interval: its bounds are
    then taken over the corners of each joint box, which is exact for constraints
    that are monotone in each joint (the coupled limits arms have are linear).
    """
    if not isinstance(q, Interval):
        return np.asarray(c(q), dtype=float)
    try:
        return iv.as_interval(c(q))
    except (TypeError, ValueError):
        n = q.lo.shape[-1]
        corners = np.array([[(k >> j) & 1 for j in range(n)] for k in range(2**n)], dtype=bool)
        vals = np.stack([np.asarray(c(np.where(m, q.hi, q.lo)), dtype=float) for m in corners])
        return Interval(vals.min(axis=0), vals.max(axis=0))


class RevolvedInclusion:
    """Tight interval bounds for a solid of revolution clipped to an azimuth sector.

    When the constraints depend on ``(r, z)`` only (``r`` the distance from the z
    axis) plus the base joint's sector, the (r, z) section is covered once with
    :func:`cover` to ``cell`` mm and tabulated (summed-area tables of its inner
    and undecided cells). A 3-D box is then bounded by the cells its (r, z)
    footprint touches: inside if they are all inner, outside if none is inner or
    undecided. This is an inclusion function like any other for :func:`cover`,
    without the overestimation that chained interval operations suffer from.
    """

    def __init__(
        self,
        profile: Callable[[Any, Any], list[Any]],
        sector: Callable[[Any], Any] | None,
        r_max: float,
        z_range: tuple[float, float],
        cell: float,
    ) -> None:
        self.sector = sector
        section_fn = lambda q: profile(q[..., 0], q[..., 1])  # noqa: E731
        # A coarse pass finds where the section is, so the fine grid spans only that.
        rough = cover(section_fn, [0.0, z_range[0]], [r_max, z_range[1]], 16 * cell)
        found_lo = np.concatenate([rough.inner_lo, rough.boundary_lo])
        found_hi = np.concatenate([rough.inner_hi, rough.boundary_hi])
        if len(found_lo) == 0:
            found_lo, found_hi = (
                np.array([[0.0, z_range[0]]]),
                np.array([[cell, z_range[0] + cell]]),
            )
        # Dyadic grid of square cells: the covering's boxes are halvings of the root
        # box, so with square cells and a root of 2^k cells each box is whole cells
        # (longest-edge halving never cuts a cell in two).
        self.origin = found_lo.min(axis=0)
        extent = found_hi.max(axis=0) - self.origin
        self.kr = max(1, int(np.ceil(np.log2(extent[0] / cell))))
        self.kz = max(1, int(np.ceil(np.log2(extent[1] / cell))))
        self.cells = np.array([2**self.kr, 2**self.kz])
        self.step = np.array([cell, cell], dtype=float)
        top = self.origin + self.cells * cell
        section = cover(section_fn, self.origin, top, cell * np.sqrt(2.0))
        self.section = section
        # One table holds both counts (inner in the low 32 bits, undecided above them)
        # so a query reads four entries, not eight.
        self._packed = self._table(section.inner_lo, section.inner_hi).astype(np.int64) + (
            self._table(section.boundary_lo, section.boundary_hi).astype(np.int64) << 32
        )

    def _table(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Summed-area table ``(Nr + 1, Nz + 1)`` of the cells covered by the boxes."""
        i0 = np.rint((lo - self.origin) / self.step).astype(np.int64)
        i1 = np.rint((hi - self.origin) / self.step).astype(np.int64)
        diff = np.zeros((self.cells[0] + 1, self.cells[1] + 1), dtype=np.int32)
        for dr, dz, sign in (
            (i0[:, 0], i0[:, 1], 1),
            (i1[:, 0], i0[:, 1], -1),
            (i0[:, 0], i1[:, 1], -1),
            (i1[:, 0], i1[:, 1], 1),
        ):
            np.add.at(diff, (dr, dz), sign)
        # The boxes are disjoint, so the integrated differences are 0 or 1 per cell.
        filled = diff.cumsum(axis=1, dtype=np.int32).cumsum(axis=0, dtype=np.int32)[:-1, :-1]
        table = np.zeros((self.cells[0] + 1, self.cells[1] + 1), dtype=np.int32)
        table[1:, 1:] = filled.cumsum(axis=1, dtype=np.int32).cumsum(axis=0, dtype=np.int32)
        return table

    def _count(self, table: np.ndarray, a0, a1, b0, b1) -> np.ndarray:
        return table[a1, b1] - table[a0, b1] - table[a1, b0] + table[a0, b0]

    def __call__(self, p: Any) -> list[Any]:
        """Constraint values for :func:`cover`: ``[-1, -1]`` inside, ``[1, 1]`` outside, else ``[-1, 1]``."""
        x, y, z = p[..., 0], p[..., 1], p[..., 2]
        cx = np.clip(0.0, x.lo, x.hi)
        cy = np.clip(0.0, y.lo, y.hi)
        r_lo = np.hypot(cx, cy)
        r_hi = np.hypot(
            np.maximum(np.abs(x.lo), np.abs(x.hi)), np.maximum(np.abs(y.lo), np.abs(y.hi))
        )
        a0 = np.floor((r_lo - self.origin[0]) / self.step[0]).astype(np.int64)
        a1 = np.ceil((r_hi - self.origin[0]) / self.step[0]).astype(np.int64)
        b0 = np.floor((z.lo - self.origin[1]) / self.step[1]).astype(np.int64)
        b1 = np.ceil((z.hi - self.origin[1]) / self.step[1]).astype(np.int64)
        a1 = np.maximum(a1, a0 + 1)
        b1 = np.maximum(b1, b0 + 1)
        total = (a1 - a0) * (b1 - b0)
        a0, a1 = np.clip(a0, 0, self.cells[0]), np.clip(a1, 0, self.cells[0])
        b0, b1 = np.clip(b0, 0, self.cells[1]), np.clip(b1, 0, self.cells[1])
        packed = self._count(self._packed, a0, a1, b0, b1)
        inner = packed & 0xFFFFFFFF
        some = inner + (packed >> 32)
        lo = np.where(some == 0, 1.0, -1.0)
        hi = np.where(inner == total, -1.0, 1.0)
        gs: list[Any] = [Interval(lo, hi)]
        if self.sector is not None:
            gs.append(self.sector(p))
        return gs


@dataclass
class WorkspaceShape:
    """An arm's reachable tool positions as a constraint system ``g_j(p) <= 0`` (mm).

    ``lower`` / ``upper`` bound the set (the covering's starting box). An arm
    whose reachable set is a plane section swept round its base axis also gives
    that ``section(r, z)`` (a list of ``g_j``) and its base's ``sector(p)``
    (None for a full turn), so the covering can bound boxes through the section.
    An arm plugin's kinematic model returns one from ``workspace_shape()``.
    """

    constraints: ConstraintSystem
    lower: np.ndarray
    upper: np.ndarray
    section: Callable[[Any, Any], list[Any]] | None = None
    sector: Callable[[Any], Any] | None = None


class ArmWorkspace:
    """The reachable tool positions of an arm (mm), from its joint limits and constraints.

    The arm's kinematic model describes its workspace: ``workspace_shape()``
    returning a :class:`WorkspaceShape`, or the older pair ``workspace_constraints``
    (``g_j(p) <= 0`` for p ``(..., 3)``, written with :mod:`armtree.maths.motion.interval`
    functions) and ``workspace_bounds()``. A model that describes none gets an
    IK-based :meth:`reachable` and no covering.
    """

    def __init__(self, model: KinematicModel) -> None:
        self.model = model
        self.system: ConstraintSystem | None = None
        self.bounds: tuple[np.ndarray, np.ndarray] | None = None
        #: Which description is in use: ``"model"`` (the model's constraints) or ``"ik"``.
        self.kind = "ik"
        self._section: Callable[[Any, Any], list[Any]] | None = None
        self._sector: Callable[[Any], Any] | None = None
        describe = getattr(model, "workspace_shape", None)
        shape = describe() if callable(describe) else None
        if shape is not None:
            self.kind, self.system = "model", shape.constraints
            self.bounds = (np.asarray(shape.lower, float), np.asarray(shape.upper, float))
            self._section, self._sector = shape.section, shape.sector
        elif hasattr(model, "workspace_constraints"):
            bounds_of = getattr(model, "workspace_bounds", None)
            if not callable(bounds_of):
                raise ConfigError(
                    f"arm model {model.name!r} has workspace_constraints but no "
                    "workspace_bounds() to say the box they are covered in"
                )
            self.kind, self.system = "model", model.workspace_constraints
            b_lo, b_hi = bounds_of()
            self.bounds = (np.asarray(b_lo, dtype=float), np.asarray(b_hi, dtype=float))

    @property
    def has_covering(self) -> bool:
        """True when the arm's workspace is described by constraints (so it can be covered)."""
        return self.system is not None

    def cover(self, delta: float, max_boxes: int = 20_000_000) -> Covering:
        """Rybak 2016's covering of the reachable workspace to box diameter ``delta`` mm."""
        if self.system is None or self.bounds is None:
            raise ConfigError(
                f"arm model {self.model.name!r} does not describe its workspace as constraints "
                "(workspace_constraints / workspace_bounds), so it cannot be covered"
            )
        lo, hi = self.bounds
        system = self.system
        if self._section is not None:
            # A solid of revolution: bound boxes through its tabulated (r, z) section.
            system = RevolvedInclusion(
                self._section, self._sector, hi[0], (lo[2], hi[2]), delta / 4
            )
        return cover(system, lo, hi, delta, max_boxes)

    def require(self, xyz: np.ndarray) -> np.ndarray:
        """``xyz`` (mm) as a float array, or :class:`~armtree.errors.Unreachable` saying why not."""
        p = np.asarray(xyz, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise Unreachable(f"target {p.tolist()} is not a finite (x, y, z) in mm")
        if not self.reachable(p):
            raise Unreachable(
                f"{self.model.name}: {np.round(p, 2).tolist()} mm is outside the reachable "
                "workspace (joint limits and coupled constraints)"
            )
        return p

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
