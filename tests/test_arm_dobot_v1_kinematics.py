"""Dobot V1.0 kinematics (Showers 2016 eqs. 1-13): round trips, limits, reach, boxes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.errors import Unreachable
from armtree.maths.motion.kinematics import KinematicModel
from armtree.plugins.arms.dobot_v1.kinematics import DobotV1Model

MODEL = DobotV1Model()


@st.composite
def limited_q(draw):
    q0 = draw(st.floats(-135, 135))
    q1 = draw(st.floats(0, 25))
    q2 = draw(st.floats(q1 + 35, 60))
    return np.array([q0, q1, q2])


def test_forward_kinematics_known_points():
    # q = 0, 0, 0: rear arm vertical, forearm horizontal (Showers 2016, eqs. 5-7)
    assert np.allclose(MODEL.position([0, 0, 0]), [160 + 55, 0, 135])
    assert np.allclose(MODEL.position([90, 90, 90]), [0, 135 + 55, -160], atol=1e-9)
    assert np.allclose(MODEL.fk([30, 10, 50])[:3, 3], MODEL.position([30, 10, 50]))


@settings(max_examples=200)
@given(limited_q())
def test_ik_of_fk_contains_q(q):
    sols = MODEL.ik_all(MODEL.position(q))
    finite = sols[np.all(np.isfinite(sols), axis=-1)]
    assert len(finite) >= 1
    assert np.min(np.linalg.norm(finite - q, axis=-1)) < 1e-6


@settings(max_examples=200)
@given(limited_q())
def test_fk_of_ik_is_p(q):
    p = MODEL.position(q)
    assert np.allclose(MODEL.position(MODEL.ik(p)), p, atol=1e-6)


@settings(max_examples=100)
@given(st.floats(-400, 400), st.floats(-400, 400), st.floats(-300, 300))
def test_points_outside_the_workspace_are_unreachable(x, y, z):
    p = np.array([x, y, z])
    sols = MODEL.ik_all(p)
    finite = sols[np.all(np.isfinite(sols), axis=-1)]
    if len(finite) == 0:
        with pytest.raises(Unreachable):
            MODEL.ik(p)
    else:
        # every returned solution is within the limits and reaches p
        assert np.all(MODEL.within_limits(finite))
        assert np.allclose(MODEL.position(finite), p, atol=1e-6)


def test_far_point_and_nan_are_unreachable():
    with pytest.raises(Unreachable, match="outside the workspace"):
        MODEL.ik([1000.0, 0.0, 0.0])
    with pytest.raises(Unreachable, match="not finite"):
        MODEL.ik([np.nan, 0.0, 0.0])


def test_coupled_limit_is_a_constraint():
    (c,) = MODEL.constraints
    assert c.g(np.array([0, 10, 50])) < 0
    assert c.g(np.array([0, 10, 40])) > 0
    assert not MODEL.within_limits(np.array([0.0, 20.0, 50.0]))
    assert MODEL.within_limits(np.array([0.0, 10.0, 50.0]))
    assert MODEL.within_limits(MODEL.home)


def test_batched_shapes():
    q = np.random.default_rng(1).uniform([-135, 0, 35], [135, 25, 60], size=(7, 5, 3))
    assert MODEL.fk(q).shape == (7, 5, 4, 4)
    assert MODEL.link_frames(q).shape == (7, 5, 4, 4, 4)
    assert MODEL.ik_all(MODEL.position(q)).shape == (7, 5, 2, 3)
    assert MODEL.jacobian(q).shape == (7, 5, 3, 3)
    assert MODEL.box_poses(q).shape == (7, 5, 4, 4, 4)


def test_analytic_jacobian_matches_central_differences():
    q = np.array([[20.0, 10.0, 50.0], [-80.0, 3.0, 59.0]])
    assert np.allclose(MODEL.jacobian(q), KinematicModel.jacobian(MODEL, q), atol=1e-6)


def test_link_frames_follow_eqs_11_to_13():
    q = np.array([30.0, 20.0, 55.0])
    frames = MODEL.link_frames(q)
    t0, t1, t2 = np.radians(q)
    elbow = 135 * np.array([np.cos(t0) * np.sin(t1), np.sin(t0) * np.sin(t1), np.cos(t1)])
    assert np.allclose(frames[1, :3, 3], elbow)
    # the rear arm's frame z axis points along the rear arm
    assert np.allclose(frames[0, :3, 2] * 135, elbow)
    wrist = elbow + 160 * np.array([np.cos(t0) * np.cos(t2), np.sin(t0) * np.cos(t2), -np.sin(t2)])
    assert np.allclose(frames[2, :3, 3], wrist)
    assert np.allclose(frames[1, :3, 0] * 160, wrist - elbow)
    assert np.allclose(frames[3, :3, 3], MODEL.position(q))
    names = [b.name for b in MODEL.boxes]
    assert names == ["rear_arm", "forearm", "tool", "camera"]


def test_tool_offset_and_drop_from_the_profile():
    m = DobotV1Model(tool_offset_mm=50.9, tool_drop_mm=70.0)
    assert np.allclose(m.position([0, 0, 0]), [160 + 50.9, 0, 135 - 70])
    assert np.allclose(m.tool_offset, [50.9, 0, -70])
    q = np.array([10.0, 15.0, 55.0])
    assert np.allclose(m.ik(m.position(q)), q)


def test_elbow_reversed_branch_is_excluded_by_the_limits():
    q = np.array([0.0, 10.0, 50.0])
    sols = MODEL.ik_all(MODEL.position(q))
    assert np.all(np.isnan(sols[1]))
