"""Interval arithmetic over numpy arrays, for box covering (Rybak 2016, eqs. 7-8 and 11).

An :class:`Interval` holds arrays ``lo`` and ``hi`` of the same shape: many
intervals at once, so a whole level of boxes is evaluated in a few numpy calls.
Every operation returns an enclosure of the true range (rounding aside, which
is far below the millimetre scales armtree works at):

``+ - * /`` (by an interval containing zero: the whole line), integer powers
(``x ** 2`` is the tight square, not ``x * x``), :func:`sqrt`, :func:`sin`,
:func:`cos`, :func:`atan2`, :func:`acos`, :func:`hypot`, :func:`maximum`.

The module-level functions also accept plain floats and arrays, so one
constraint function serves both for interval bounds and for point tests.
Angles are in radians here.
"""

from __future__ import annotations

from typing import Any

import numpy as np

_TWO_PI = 2.0 * np.pi


class Interval:
    """Intervals ``[lo, hi]`` elementwise over arrays (broadcasting like numpy)."""

    __slots__ = ("lo", "hi")
    __array_ufunc__ = None  # so ``ndarray + Interval`` defers to Interval.__radd__

    def __init__(self, lo: Any, hi: Any = None) -> None:
        self.lo = np.asarray(lo, dtype=float)
        self.hi = self.lo if hi is None else np.asarray(hi, dtype=float)

    # -- access -----------------------------------------------------------------

    def __getitem__(self, key: Any) -> Interval:
        return Interval(self.lo[key], self.hi[key])

    @property
    def shape(self) -> tuple[int, ...]:
        """Broadcast shape of the bounds."""
        return np.broadcast_shapes(self.lo.shape, self.hi.shape)

    @property
    def width(self) -> np.ndarray:
        """``hi - lo``."""
        return self.hi - self.lo

    @property
    def mid(self) -> np.ndarray:
        """Midpoints."""
        return 0.5 * (self.lo + self.hi)

    def contains(self, x: Any) -> np.ndarray:
        """Boolean: ``lo <= x <= hi``."""
        return (self.lo <= x) & (x <= self.hi)

    def __repr__(self) -> str:
        return f"Interval({self.lo!r}, {self.hi!r})"

    # -- arithmetic ---------------------------------------------------------------

    def __neg__(self) -> Interval:
        return Interval(-self.hi, -self.lo)

    def __pos__(self) -> Interval:
        return self

    def __add__(self, other: Any) -> Interval:
        o = as_interval(other)
        return Interval(self.lo + o.lo, self.hi + o.hi)

    __radd__ = __add__

    def __sub__(self, other: Any) -> Interval:
        o = as_interval(other)
        return Interval(self.lo - o.hi, self.hi - o.lo)

    def __rsub__(self, other: Any) -> Interval:
        return as_interval(other) - self

    def __mul__(self, other: Any) -> Interval:
        if not isinstance(other, Interval):
            if isinstance(other, (int, float)):
                # A plain number keeps or swaps the ends: two products, no min/max.
                if other >= 0:
                    return Interval(self.lo * other, self.hi * other)
                return Interval(self.hi * other, self.lo * other)
            c = np.asarray(other, dtype=float)
            a, b = self.lo * c, self.hi * c
            return Interval(np.minimum(a, b), np.maximum(a, b))
        # Overflow to +-inf is a valid (outward) bound; 0 * inf is repaired below.
        with np.errstate(invalid="ignore", over="ignore"):
            p1, p2 = self.lo * other.lo, self.lo * other.hi
            p3, p4 = self.hi * other.lo, self.hi * other.hi
        if not np.all(np.isfinite(self.lo) & np.isfinite(self.hi)) or not np.all(
            np.isfinite(other.lo) & np.isfinite(other.hi)
        ):
            # 0 * inf is 0 for intervals (the zero factor is exact); numpy says NaN.
            p1, p2, p3, p4 = (
                np.nan_to_num(p, nan=0.0, posinf=np.inf, neginf=-np.inf) for p in (p1, p2, p3, p4)
            )
        return Interval(
            np.minimum(np.minimum(p1, p2), np.minimum(p3, p4)),
            np.maximum(np.maximum(p1, p2), np.maximum(p3, p4)),
        )

    __rmul__ = __mul__

    def reciprocal(self) -> Interval:
        """``1 / x``; the whole line where ``x`` contains zero."""
        zero = (self.lo <= 0) & (self.hi >= 0)
        with np.errstate(divide="ignore", over="ignore"):
            lo = np.where(zero, -np.inf, 1.0 / self.hi)
            hi = np.where(zero, np.inf, 1.0 / self.lo)
        return Interval(lo, hi)

    def __truediv__(self, other: Any) -> Interval:
        if not isinstance(other, Interval):
            return self * (1.0 / np.asarray(other, dtype=float))
        return self * other.reciprocal()

    def __rtruediv__(self, other: Any) -> Interval:
        return as_interval(other) * self.reciprocal()

    def __pow__(self, n: int) -> Interval:
        if not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"interval powers must be non-negative integers, got {n!r}")
        if n == 0:
            one = np.ones(self.shape)
            return Interval(one, one)
        lo_n, hi_n = self.lo**n, self.hi**n
        if n % 2:
            return Interval(lo_n, hi_n)
        zero = (self.lo <= 0) & (self.hi >= 0)
        return Interval(np.where(zero, 0.0, np.minimum(lo_n, hi_n)), np.maximum(lo_n, hi_n))


def as_interval(x: Any) -> Interval:
    """``x`` if it is an Interval, else the degenerate interval ``[x, x]``."""
    return x if isinstance(x, Interval) else Interval(x)


def sqrt(x: Any) -> Any:
    """Square root; an interval is clipped to its non-negative part first."""
    if isinstance(x, Interval):
        return Interval(np.sqrt(np.maximum(x.lo, 0.0)), np.sqrt(np.maximum(x.hi, 0.0)))
    return np.sqrt(x)


def _periodic_range(x: Interval, f: Any, peak: float, trough: float) -> Interval:
    """Range of sin/cos: the end values, widened to +-1 where a peak or trough lies inside."""
    a, b = f(x.lo), f(x.hi)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    # Is there k with peak + 2 pi k in [x.lo, x.hi]?
    has_peak = np.ceil((x.lo - peak) / _TWO_PI) <= np.floor((x.hi - peak) / _TWO_PI)
    has_trough = np.ceil((x.lo - trough) / _TWO_PI) <= np.floor((x.hi - trough) / _TWO_PI)
    return Interval(np.where(has_trough, -1.0, lo), np.where(has_peak, 1.0, hi))


def sin(x: Any) -> Any:
    """Sine (radians)."""
    if isinstance(x, Interval):
        return _periodic_range(x, np.sin, 0.5 * np.pi, -0.5 * np.pi)
    return np.sin(x)


def cos(x: Any) -> Any:
    """Cosine (radians)."""
    if isinstance(x, Interval):
        return _periodic_range(x, np.cos, 0.0, np.pi)
    return np.cos(x)


def atan2(y: Any, x: Any) -> Any:
    """``atan2(y, x)`` in ``(-pi, pi]``.

    Over a box that holds the origin or crosses the branch cut (x < 0, y = 0)
    the range is ``[-pi, pi]``; elsewhere atan2 is monotone along each edge of
    the box, so the corners bound it.
    """
    if not isinstance(y, Interval) and not isinstance(x, Interval):
        return np.arctan2(y, x)
    y, x = as_interval(y), as_interval(x)
    # -0.0 and 0.0 are the same point; atan2 tells them apart (-pi vs pi), so fold to +0.
    y = Interval(y.lo + 0.0, y.hi + 0.0)
    corners = [np.arctan2(a, b) for a in (y.lo, y.hi) for b in (x.lo, x.hi)]
    lo = np.minimum(np.minimum(corners[0], corners[1]), np.minimum(corners[2], corners[3]))
    hi = np.maximum(np.maximum(corners[0], corners[1]), np.maximum(corners[2], corners[3]))
    whole = (x.lo < 0) & (y.lo < 0) & (y.hi >= 0)
    whole |= (x.lo <= 0) & (x.hi >= 0) & (y.lo <= 0) & (y.hi >= 0)
    return Interval(np.where(whole, -np.pi, lo), np.where(whole, np.pi, hi))


def acos(x: Any) -> Any:
    """Arc cosine (radians); arguments are clipped to ``[-1, 1]`` first."""
    if isinstance(x, Interval):
        lo, hi = np.clip(x.lo, -1.0, 1.0), np.clip(x.hi, -1.0, 1.0)
        return Interval(np.arccos(hi), np.arccos(lo))
    return np.arccos(np.clip(x, -1.0, 1.0))


def hypot(x: Any, y: Any) -> Any:
    """``sqrt(x**2 + y**2)`` with tight squares."""
    if isinstance(x, Interval) or isinstance(y, Interval):
        return sqrt(as_interval(x) ** 2 + as_interval(y) ** 2)
    return np.hypot(x, y)


def maximum(a: Any, b: Any) -> Any:
    """Elementwise maximum (for constraints ``max(g1, g2) <= 0``: a union of regions)."""
    if isinstance(a, Interval) or isinstance(b, Interval):
        a, b = as_interval(a), as_interval(b)
        return Interval(np.maximum(a.lo, b.lo), np.maximum(a.hi, b.hi))
    return np.maximum(a, b)


def minimum(a: Any, b: Any) -> Any:
    """Elementwise minimum."""
    if isinstance(a, Interval) or isinstance(b, Interval):
        a, b = as_interval(a), as_interval(b)
        return Interval(np.minimum(a.lo, b.lo), np.minimum(a.hi, b.hi))
    return np.minimum(a, b)
