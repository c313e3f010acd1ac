"""Dobot Magician kinematics: closed forms, fk(ik(p)) == p, ik(fk(q)) contains q, Unreachable."""

import numpy as np
import pytest
from hypothesis import given, settings
from kinematic_checks import (
    assert_fk_of_ik_is_the_target,
    assert_ik_of_fk_contains_q,
    joint_configs,
)

from armtree.errors import Unreachable
from armtree.plugins.arms.dobot_magician.kinematics import MagicianModel

MODEL = MagicianModel()


def test_known_pose():
    # J = (0, 0, 0, 0): rear arm vertical, forearm level: x = L2 + tool, z = L1
    p = MODEL.position(np.zeros(4))
    np.testing.assert_allclose(p, [147 + 59.7, 0, 135], atol=1e-9)
    np.testing.assert_allclose(MODEL.pose_xyzr(np.array([30, 0, 0, 10]))[3], 40)


@settings(max_examples=200, deadline=None)
@given(joint_configs(MODEL))
def test_ik_of_fk_contains_q(q):
    assert_ik_of_fk_contains_q(MODEL, q)


@settings(max_examples=200, deadline=None)
@given(joint_configs(MODEL))
def test_fk_of_ik_is_the_target(q):
    good = assert_fk_of_ik_is_the_target(MODEL, q)
    assert np.all(MODEL.within_limits(good))


def test_batched_shapes_and_link_frames_agree():
    rng = np.random.default_rng(0)
    q = rng.uniform(MODEL.lower, MODEL.upper, size=(5, 7, 4))
    assert MODEL.fk(q).shape == (5, 7, 4, 4)
    assert MODEL.ik_all(MODEL.position(q)).shape == (5, 7, 2, 4)
    np.testing.assert_allclose(MODEL.fk(q)[..., :3, 3], MODEL.position(q), atol=1e-9)
    assert MODEL.box_poses(q).shape == (5, 7, len(MODEL.boxes), 4, 4)
    assert MODEL.jacobian(q[0, 0]).shape == (3, 4)


@pytest.mark.parametrize("target", [[1000, 0, 0], [0, 0, 500], [-200, 0, 0], [np.nan, 0, 0]])
def test_outside_workspace_is_unreachable(target):
    with pytest.raises(Unreachable, match="target"):
        MODEL.ik(np.array(target, dtype=float))


def test_closed_form_fk_equals_the_link_frames_tool():
    q = np.random.default_rng(3).uniform(MODEL.lower, MODEL.upper, size=(200, 4))
    np.testing.assert_allclose(MODEL.fk(q), MODEL.link_frames(q)[..., -1, :, :], atol=1e-9)
