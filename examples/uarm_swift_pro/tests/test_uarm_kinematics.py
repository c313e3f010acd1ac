"""The Swift Pro's kinematics against the firmware's numbers, and their round trips."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree_uarm_swift_pro.kinematics import SwiftProModel

MODEL = SwiftProModel()


@pytest.mark.parametrize(
    ("xyz", "joints"),
    [
        # From the firmware's formulas (uarm_coord_convert.c), mode 0: (base, left, right).
        ((200, 0, 150), (90.0, 100.99, 8.08)),
        ((300, 0, 150), (90.0, 59.81, 2.04)),
        ((200, 100, 100), (116.57, 84.59, 27.89)),
        ((150, -150, 30), (45.0, 66.75, 57.13)),
    ],
)
def test_inverse_kinematics_gives_the_firmware_angles(xyz, joints):
    q = MODEL.ik(np.array(xyz, dtype=float))
    assert q == pytest.approx(joints, abs=0.01)
    assert MODEL.position(q) == pytest.approx(xyz, abs=1e-9)


@pytest.mark.parametrize(
    ("xyz", "reachable"),
    [
        ((134, 0, 150), True),  # the reach at z = 150 is x = 134..322 mm
        ((130, 0, 150), False),
        ((322, 0, 150), True),
        ((326, 0, 150), False),
        ((358, 0, 0), True),  # about 359 mm at the table top
        ((362, 0, 0), False),
        ((0, 0, 45), False),  # uArm-Python-SDK issue 14: "the arm doesn't move"
        ((-150, 0, 100), False),  # x < 0 is behind the base
    ],
)
def test_the_workspace_is_the_firmwares(xyz, reachable):
    solutions = MODEL.ik_all(np.array(xyz, dtype=float))
    assert bool(np.isfinite(solutions).all(axis=-1).any()) is reachable


joints = st.tuples(st.floats(0, 180), st.floats(-4, 135.6), st.floats(-4, 119.9))


@settings(max_examples=150, deadline=None)
@given(joints)
def test_inverse_kinematics_finds_every_pose_forward_kinematics_reaches(q):
    q = np.array(q)
    if not MODEL.within_limits(q):
        return
    p = MODEL.position(q)
    solutions = MODEL.ik_all(p)
    assert np.any(np.all(np.isclose(solutions, q, rtol=1e-6, atol=1e-6), axis=-1))
    # The last link frame is the tool centre the closed form gives.
    assert MODEL.link_frames(q)[-1][:3, 3] == pytest.approx(p, rel=1e-9, abs=1e-9)


def test_the_arms_angle_is_a_coupled_limit():
    folded = np.array([90.0, 100.0, 75.0])  # each joint within its range, the arms 5 degrees apart
    assert not MODEL.within_limits(folded)
    assert MODEL.within_limits(np.array([90.0, 100.0, 60.0]))


def test_the_workspace_constraints_agree_with_the_inverse_kinematics():
    # armtree's workspace tool and planners test targets with the constraints; a point
    # the constraints accept must have an IK solution within the limits, and back.
    from armtree.maths.motion.workspace import ArmWorkspace

    workspace = ArmWorkspace(MODEL)
    assert workspace.kind == "model" and workspace.has_covering
    points = np.random.default_rng(3).uniform([-50, -380, -280], [380, 380, 340], (20000, 3))
    by_ik = np.isfinite(MODEL.ik_all(points)).all(axis=-1).any(axis=-1)
    assert by_ik.sum() > 3000
    assert np.array_equal(workspace.reachable(points), by_ik)
