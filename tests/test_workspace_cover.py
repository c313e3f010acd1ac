"""Interval arithmetic encloses true ranges; Rybak 2016's covering; each arm's reachable workspace."""

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from planning_models import DobotLike, PlanarArm, wide_dobot

from armtree.errors import ConfigError
from armtree.maths.motion import interval as iv
from armtree.maths.motion.interval import Interval
from armtree.maths.motion.workspace import ArmWorkspace, cover, satisfied, sector_constraint

finite = st.floats(-20, 20, allow_nan=False, allow_subnormal=False)


def _interval_and_points(a, b, fracs):
    lo, hi = min(a, b), max(a, b)
    pts = np.clip(lo + np.array(fracs) * (hi - lo), lo, hi)
    return Interval(lo, hi), pts


def _encloses(result, values):
    # Rounding of the last bit is allowed (the module does not round outward); a value
    # that overflowed to infinity (4 / 2**-1022) must be met by an infinite bound.
    tol = np.where(np.isfinite(values), 1e-9 * (1 + np.abs(values)), 0.0)
    return np.all(result.lo <= values + tol) and np.all(values <= result.hi + tol)


fracs = st.lists(st.floats(0, 1), min_size=1, max_size=20)


@settings(max_examples=200, deadline=None)
@given(finite, finite, finite, finite, fracs, fracs)
@example(0.0, -4.0, 1.0, 2.2250738585072014e-308, [0.0], [0.0])  # -4 / 2**-1022 overflows
def test_property_arithmetic_encloses_point_values(a, b, c, d, f1, f2):
    x, xs = _interval_and_points(a, b, f1)
    y, ys = _interval_and_points(c, d, f2)
    X, Y = np.meshgrid(xs, ys)
    assert _encloses(x + y, X + Y)
    assert _encloses(x - y, X - Y)
    assert _encloses(x * y, X * Y)
    assert _encloses(x**2, X**2) and _encloses(x**3, X**3)
    assert _encloses(3.0 - x * 2.0, 3.0 - X * 2.0)
    if not y.contains(0.0):
        # the point values may overflow to inf, as the interval's bounds do
        with np.errstate(over="ignore"):
            quotients = X / Y
        assert _encloses(x / y, quotients)
    elif not x.contains(0.0):
        q = x / y
        assert q.lo == -np.inf or q.hi == np.inf
    assert _encloses(iv.sqrt(x**2 + y**2), np.hypot(X, Y))


@settings(max_examples=200, deadline=None)
@given(finite, finite, finite, finite, fracs, fracs)
def test_property_transcendentals_enclose_point_values(a, b, c, d, f1, f2):
    x, xs = _interval_and_points(a, b, f1)
    y, ys = _interval_and_points(c, d, f2)
    assert _encloses(iv.sin(x), np.sin(xs)) and _encloses(iv.cos(x), np.cos(xs))
    Y, X = np.meshgrid(ys, xs)
    assert _encloses(iv.atan2(y, x), np.arctan2(Y, X))
    u, us = _interval_and_points(a / 20, b / 20, f1)
    assert _encloses(iv.acos(u), np.arccos(us))


def test_tightness_of_simple_cases():
    x = Interval(-1.0, 2.0)
    sq = x**2
    assert (sq.lo, sq.hi) == (0.0, 4.0)  # the tight square, not x * x = [-2, 4]
    s = iv.sin(Interval(0.0, math.pi))
    assert s.lo == pytest.approx(0, abs=1e-12) and s.hi == 1.0
    a = iv.atan2(Interval(1.0, 2.0), Interval(1.0, 2.0))
    assert a.lo == pytest.approx(math.atan2(1, 2)) and a.hi == pytest.approx(math.atan2(2, 1))
    cut = iv.atan2(Interval(-1.0, 1.0), Interval(-2.0, -1.0))
    assert (cut.lo, cut.hi) == (-math.pi, math.pi)
    v = np.array([1.0, 2.0]) + Interval(np.array([0.0, 1.0]), np.array([1.0, 3.0]))
    np.testing.assert_array_equal(v.hi, [2.0, 5.0])
    with pytest.raises(ValueError):
        x**-1


# -- Rybak 2016's planar parallel robot ---------------------------------------------

L_MIN, L_MAX, L0 = 8.0, 12.0, 5.0


def _robot(x):
    x1, x2 = x[..., 0], x[..., 1]
    return [
        x1**2 + x2**2 - L_MAX**2,
        L_MIN**2 - x1**2 - x2**2,
        (x1 - L0) ** 2 + x2**2 - L_MAX**2,
        L_MIN**2 - (x1 - L0) ** 2 - x2**2,
    ]


def _lens(r1, r2, d):
    a = r1**2 * math.acos((d * d + r1 * r1 - r2 * r2) / (2 * d * r1))
    a += r2**2 * math.acos((d * d + r2 * r2 - r1 * r1) / (2 * d * r2))
    return a - 0.5 * math.sqrt((-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2))


ANALYTIC = 0.5 * (
    _lens(L_MAX, L_MAX, L0)
    - _lens(L_MIN, L_MAX, L0)
    - _lens(L_MAX, L_MIN, L0)
    + _lens(L_MIN, L_MIN, L0)
)


def test_seed_003_planar_robot_inner_analytic_outer():
    boundary = []
    for delta in (0.5, 0.25, 0.07):
        # The source document's box: lower left (-l_max, 0), l_max + l0 + l_max wide, min(l_max) high.
        c = cover(_robot, [-L_MAX, 0.0], [L_MAX + L0, L_MAX], delta)
        assert c.inner_measure <= ANALYTIC <= c.inner_measure + c.boundary_measure
        size = c.boundary_hi - c.boundary_lo
        assert np.all(np.hypot(size[:, 0], size[:, 1]) <= delta + 1e-12)
        # Inner boxes really are inside: every corner satisfies every constraint.
        corners = np.concatenate(
            [c.inner_lo, c.inner_hi, np.stack([c.inner_lo[:, 0], c.inner_hi[:, 1]], 1)]
        )
        assert satisfied(_robot, corners, tol=1e-9).all()
        boundary.append(c.boundary_measure)
    assert boundary[0] > boundary[1] > boundary[2]
    assert boundary[2] < 0.1 * ANALYTIC


def test_cover_rejects_bad_boxes_and_runaway_sizes():
    with pytest.raises(ValueError):
        cover(_robot, [0.0, 0.0], [0.0, 1.0], 0.1)
    with pytest.raises(ValueError, match="live boxes"):
        cover(_robot, [-L_MAX, 0.0], [L_MAX + L0, L_MAX], 1e-4, max_boxes=1000)


def test_cover_accepts_a_list_of_constraint_functions():
    disc = [lambda x: x[..., 0] ** 2 + x[..., 1] ** 2 - 1.0]
    c = cover(disc, [-1.0, -1.0], [1.0, 1.0], 0.05)
    assert c.inner_measure <= math.pi <= c.inner_measure + c.boundary_measure


@pytest.mark.parametrize(("lo", "hi"), [(-135.0, 135.0), (-45.0, 60.0), (10.0, 200.0)])
def test_sector_constraint_matches_atan2(lo, hi):
    g = sector_constraint(lo, hi)
    rng = np.random.default_rng(0)
    p = rng.uniform(-1, 1, (5000, 2))
    ang = np.degrees(np.arctan2(p[:, 1], p[:, 0]))
    inside = ((ang >= lo) & (ang <= hi)) | ((ang + 360 >= lo) & (ang + 360 <= hi))
    np.testing.assert_array_equal(g(p) <= 0, inside)
    assert sector_constraint(-180.0, 180.0) is None


# -- arms ----------------------------------------------------------------------------------


@pytest.mark.parametrize("model", [DobotLike(), wide_dobot()], ids=["seed_limits", "wide"])
def test_dobot_reachable_agrees_with_inverse_kinematics(model):
    ws = ArmWorkspace(model)
    assert ws.has_covering
    rng = np.random.default_rng(5)
    x = rng.uniform([-400, -400, -300], [400, 400, 300], (20000, 3))
    near = model.position(model.lower + rng.random((20000, 3)) * (model.upper - model.lower))
    x = np.concatenate([x, near + rng.normal(0, 3, near.shape)])
    ik = np.any(np.all(np.isfinite(model.ik_all(x)), axis=-1), axis=-1)
    agree = ws.reachable(x) == ik
    assert ik.sum() > 1000 and agree.mean() > 0.999
    assert ws.reachable(np.array([np.nan, 0.0, 0.0])) is False


def test_dobot_covering_encloses_fk_points_and_inner_boxes_are_reachable():
    model = DobotLike()
    ws = ArmWorkspace(model)
    c = ws.cover(8.0)
    rng = np.random.default_rng(6)
    q = model.lower + rng.random((4000, 3)) * (model.upper - model.lower)
    p = model.position(q[model.within_limits(q)])
    lo = np.concatenate([c.inner_lo, c.boundary_lo])
    hi = np.concatenate([c.inner_hi, c.boundary_hi])
    covered = np.zeros(len(p), dtype=bool)
    for s in range(0, len(p), 500):
        chunk = p[s : s + 500, None]
        covered[s : s + 500] = np.any(
            np.all((chunk >= lo - 1e-9) & (chunk <= hi + 1e-9), axis=-1), axis=1
        )
    assert covered.all()
    centres = 0.5 * (c.inner_lo + c.inner_hi)
    assert len(centres) > 0
    sols = model.ik_all(centres)
    assert np.all(np.any(np.all(np.isfinite(sols), axis=-1), axis=-1))


def test_models_without_constraints_use_ik_and_cannot_be_covered():
    ws = ArmWorkspace(PlanarArm())
    assert not ws.has_covering
    assert ws.reachable(np.array([300.0, 0.0, 50.0])) is True
    assert ws.reachable(np.array([600.0, 0.0, 50.0])) is False
    with pytest.raises(ConfigError, match="cannot be covered"):
        ws.cover(5.0)
