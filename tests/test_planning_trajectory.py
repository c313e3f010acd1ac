"""Cubic and quintic joint trajectories (Pozzani 2023 eq. 2), limits, via-points, path validation."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from planning_models import PlanarArm, wide_dobot

from armtree.errors import PlanningError
from armtree.maths.motion.collision import CollisionChecker
from armtree.maths.motion.scene import Scene
from armtree.maths.motion.trajectory import (
    cubic_coefficients,
    plan_trajectory,
    quintic_coefficients,
    validate_trajectory,
)


def test_cubic_solves_seed_002_eq_2_on_any_interval():
    q0, q1, v0, v1 = (
        np.array([10.0, -5.0]),
        np.array([40.0, 25.0]),
        np.array([1.0, 0.0]),
        np.array([0.0, -2.0]),
    )
    a = cubic_coefficients(q0, q1, 2.0, 5.0, v0, v1)
    for t, q, v in ((2.0, q0, v0), (5.0, q1, v1)):
        # atol: a boundary velocity of 0 comes out as a rounding residue (1e-14), whose
        # sign and size depend on how numpy's build sums the polynomial.
        np.testing.assert_allclose(
            a[0] + a[1] * t + a[2] * t**2 + a[3] * t**3, q, rtol=1e-9, atol=1e-9
        )
        np.testing.assert_allclose(a[1] + 2 * a[2] * t + 3 * a[3] * t**2, v, rtol=1e-9, atol=1e-9)


def test_quintic_matches_all_six_boundary_conditions():
    c = quintic_coefficients(np.array([0.0]), np.array([30.0]), 2.0, 1.0, -1.0, 0.5, 0.0)
    t = 2.0
    p = np.polynomial.Polynomial(c[:, 0])
    assert p(0) == pytest.approx(0, abs=1e-9) and p(t) == pytest.approx(30)
    assert p.deriv()(0) == pytest.approx(1) and p.deriv()(t) == pytest.approx(-1)
    assert p.deriv(2)(0) == pytest.approx(0.5) and p.deriv(2)(t) == pytest.approx(0, abs=1e-9)


@pytest.mark.parametrize("kind", ["cubic", "quintic"])
def test_limits_are_respected_and_velocity_is_continuous_at_via_points(kind):
    w = np.array([[0.0, 0.0], [30.0, 10.0], [60.0, -10.0], [60.0, 40.0]])
    vmax, amax = np.array([90.0, 45.0]), np.array([360.0, 100.0])
    traj = plan_trajectory(w, kind, max_speed=vmax, max_accel=amax)
    t = np.linspace(0, traj.duration, 4001)
    assert np.all(np.abs(traj.velocity(t)) <= vmax * 1.001)
    assert np.all(np.abs(traj.acceleration(t)) <= amax * 1.001)
    # A limit is reached somewhere: the durations are not padded needlessly.
    assert (
        np.max(np.abs(traj.velocity(t)) / vmax) > 0.95
        or np.max(np.abs(traj.acceleration(t)) / amax) > 0.95
    )
    np.testing.assert_allclose(traj.position(traj.times), w, atol=1e-9)
    np.testing.assert_allclose(traj.velocity(np.array([0.0, traj.duration])), 0, atol=1e-9)
    eps = 1e-7
    jump = traj.velocity(traj.times[1:-1] - eps) - traj.velocity(traj.times[1:-1] + eps)
    assert np.abs(jump).max() < 1e-3
    # Joint 1 turns back at the second via-point: it stops there.
    np.testing.assert_allclose(traj.velocity(traj.times[2])[1], 0, atol=1e-9)


def test_given_durations_and_sampling():
    traj = plan_trajectory(np.array([[0.0], [10.0], [10.0], [30.0]]), durations=[1.0, 0.5, 2.0])
    assert traj.duration == pytest.approx(3.0)  # the repeated waypoint is merged with its segment
    np.testing.assert_allclose(traj.waypoints, [[0.0], [10.0], [30.0]], atol=1e-12)
    times, q = traj.sample(0.1)
    assert times[0] == 0 and times[-1] == pytest.approx(3.0) and np.all(np.diff(times) > 0)
    assert q[0, 0] == pytest.approx(0, abs=1e-9) and q[-1, 0] == pytest.approx(30)
    with pytest.raises(ValueError):
        plan_trajectory(np.array([[0.0], [1.0]]), durations=[0.0])
    with pytest.raises(PlanningError):
        plan_trajectory(np.array([[0.0], [np.nan]]), durations=[1.0])
    with pytest.raises(ValueError):
        plan_trajectory(np.array([[0.0], [1.0]]), kind="septic", durations=[1.0])


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.floats(-170, 170), min_size=4, max_size=12),
    st.floats(10, 200),
    st.floats(20, 800),
    st.sampled_from(["cubic", "quintic"]),
)
def test_property_trajectories_pass_the_waypoints_within_limits(values, vmax, amax, kind):
    w = np.array(values[: len(values) // 2 * 2]).reshape(-1, 2)
    traj = plan_trajectory(w, kind, max_speed=vmax, max_accel=amax)
    t = np.linspace(0, traj.duration, 1500)
    assert np.all(np.abs(traj.velocity(t)) <= vmax * 1.01)
    assert np.all(np.abs(traj.acceleration(t)) <= amax * 1.01)
    np.testing.assert_allclose(traj.position(traj.duration), w[-1], atol=1e-6)
    np.testing.assert_allclose(traj.position(0.0), w[0], atol=1e-9)


def test_validation_along_the_timed_path():
    model = wide_dobot()
    scene = Scene.from_profile(
        {"obstacles": [{"box": {"center": [0, 250, 50], "size": [400, 20, 300], "name": "wall"}}]}
    )
    checker = CollisionChecker(model, scene)
    limits = dict(
        max_speed=[j.max_speed for j in model.joints], max_accel=[j.max_accel for j in model.joints]
    )
    good = plan_trajectory(np.array([[-60.0, 20.0, 30.0], [30.0, 30.0, 40.0]]), **limits)
    assert validate_trajectory(good, checker).ok
    through_wall = plan_trajectory(np.array([[30.0, 30.0, 20.0], [130.0, 30.0, 20.0]]), **limits)
    report = validate_trajectory(through_wall, checker)
    assert (
        not report.ok
        and report.reason == "collision"
        and "wall" in report.message
        and "t =" in report.message
    )
    rushed = plan_trajectory(np.array([[0.0, 20.0, 30.0], [90.0, 20.0, 30.0]]), durations=[0.2])
    assert validate_trajectory(rushed, checker).reason == "too_fast"
    with pytest.raises(PlanningError):
        validate_trajectory(through_wall, checker).raise_if_bad()


def test_validation_catches_singularities():
    model = PlanarArm()
    checker = CollisionChecker(model, Scene())
    traj = plan_trajectory(np.array([[0.0, 90.0], [0.0, -90.0]]), max_speed=90, max_accel=360)
    assert validate_trajectory(traj, checker).ok
    report = validate_trajectory(traj, checker, min_singular=0.5)
    assert report.reason == "singular"
