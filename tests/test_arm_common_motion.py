"""Joint motion: synchronised trapezoids within the joints' speed and acceleration."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.plugins.arms.common import JointMove, JointState

VMAX = np.array([90.0, 60.0, 60.0])
AMAX = np.array([180.0, 120.0, 120.0])

angles = st.lists(st.floats(-100, 100), min_size=3, max_size=3).map(np.array)


@settings(max_examples=60)
@given(angles, angles, st.floats(0.05, 1.0))
def test_move_reaches_goal_within_limits(a, b, speed):
    move = JointMove(a, b, 1.0, VMAX, AMAX, speed)
    assert np.allclose(move.position(1.0), a)
    assert np.allclose(move.position(move.end_time), b, atol=1e-9)
    ts = np.linspace(1.0, move.end_time, 200)
    vel = np.array([move.velocity(t) for t in ts])
    assert np.all(np.abs(vel) <= VMAX * speed + 1e-6)
    pos = np.array([move.position(t) for t in ts])
    # every joint moves along the straight line from a to b (synchronised)
    d = b - a
    if np.linalg.norm(d) > 1e-9:
        s = (pos - a) @ d / (d @ d)
        assert np.allclose(pos, a + np.outer(s, d), atol=1e-6)
        assert np.all(np.diff(s) >= -1e-12)


def test_move_is_independent_of_sampling():
    move = JointMove(np.zeros(3), np.array([90.0, 30.0, -20.0]), 0.0, VMAX, AMAX)
    fine = [move.position(t) for t in np.arange(0, 2, 0.001)]
    assert np.allclose(fine[1000], move.position(1.0))


def test_brake_stops_short_of_the_goal_without_jumping():
    move = JointMove(np.zeros(3), np.array([90.0, 0, 0]), 0.0, VMAX, AMAX)
    t = move.end_time / 2
    p = move.position(t)
    move.brake(t)
    assert np.allclose(move.position(t), p)
    end = move.position(move.end_time)
    assert p[0] < end[0] < 90.0
    assert move.velocity(move.end_time)[0] == pytest.approx(0, abs=1e-9)


def test_joint_state_missed_steps_offset_true_only():
    js = JointState(np.zeros(3), VMAX, AMAX)
    js.move_to(np.array([10.0, 0, 0]), 0.0)
    js.miss_steps(0, -2.0)
    assert np.allclose(js.reported(10.0), [10, 0, 0])
    assert np.allclose(js.true(10.0), [8, 0, 0])
    js.halt(10.0)
    assert not js.moving(11.0)
