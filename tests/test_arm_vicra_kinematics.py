"""VICRA SCARA kinematics: two elbow branches, fk(ik(p)) == p, ik(fk(q)) contains q, Unreachable."""

import numpy as np
import pytest
from hypothesis import given, settings
from kinematic_checks import (
    assert_fk_of_ik_is_the_target,
    assert_ik_of_fk_contains_q,
    joint_configs,
)

from armtree.errors import Unreachable
from armtree.plugins.arms.vicra.kinematics import VicraModel

MODEL = VicraModel()


def test_reach_and_column_match_seed_000():
    # Durovic 2017: ~0.6 m vertical travel and ~0.6 m horizontal reach
    assert MODEL.joints[0].kind == "prismatic" and MODEL.joints[0].upper == 600
    np.testing.assert_allclose(MODEL.position(np.array([100, 0, 0, 0])), [600, 0, 100], atol=1e-9)
    np.testing.assert_allclose(MODEL.position(np.array([0, 90, 90, 0])), [-300, 300, 0], atol=1e-9)


def test_two_branches_mirror_the_elbow():
    sols = MODEL.ik_all(np.array([400.0, 100.0, 50.0]))
    assert np.all(np.isfinite(sols))
    assert sols[0, 2] > 0 > sols[1, 2]
    np.testing.assert_allclose(sols[0, 2], -sols[1, 2])


def test_ik_takes_the_nearer_branch():
    target = np.array([400.0, 100.0, 50.0])
    right, left = MODEL.ik_all(target)
    assert np.allclose(MODEL.ik(target, near=right + 5), right)
    assert np.allclose(MODEL.ik(target, near=left - 5), left)


@settings(max_examples=200, deadline=None)
@given(joint_configs(MODEL))
def test_ik_of_fk_contains_q(q):
    assert_ik_of_fk_contains_q(MODEL, q)


@settings(max_examples=200, deadline=None)
@given(joint_configs(MODEL))
def test_fk_of_ik_is_the_target(q):
    assert_fk_of_ik_is_the_target(MODEL, q)


def test_link_frames_agree_with_position_and_batch():
    rng = np.random.default_rng(1)
    q = rng.uniform(MODEL.lower, MODEL.upper, size=(4, 6, 4))
    np.testing.assert_allclose(MODEL.fk(q)[..., :3, 3], MODEL.position(q), atol=1e-9)
    assert MODEL.ik_all(MODEL.fk(q)).shape == (4, 6, 2, 4)
    assert MODEL.box_poses(q).shape == (4, 6, 4, 4, 4)


@pytest.mark.parametrize(
    "target", [[700, 0, 0], [0, 0, 0], [300, 0, 700], [300, 0, -5], [0, np.inf, 0]]
)
def test_outside_workspace_is_unreachable(target):
    with pytest.raises(Unreachable):
        MODEL.ik(np.array(target, dtype=float))


def test_closed_form_fk_equals_the_link_frames_tool():
    q = np.random.default_rng(3).uniform(MODEL.lower, MODEL.upper, size=(200, 4))
    np.testing.assert_allclose(MODEL.fk(q), MODEL.link_frames(q)[..., -1, :, :], atol=1e-9)
