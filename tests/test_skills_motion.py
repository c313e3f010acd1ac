"""move_to and home on fake rigs: planned waypoints, refusals, halts."""

import numpy as np
import pytest
from py_trees.common import Status
from test_skills_fakes import Marker, _clean_blackboard, make_rig, run  # noqa: F401

import armtree
from armtree.config.params import Binding
from armtree.plugins.skills.motion import Home, MoveTo


def test_move_to_place_goes_through_the_planner_waypoints():
    rig = make_rig()
    node = MoveTo("go", to="ducky_pickup", offset=[0, 0, 50], pose=Binding("reached"))
    status, _ = run(node, rig)
    assert status is Status.SUCCESS
    assert rig.planner.calls == 1 and len(rig.arm.moves) == 2  # midpoint then goal
    assert np.allclose(rig.arm.pose()[:3, 3], [180, -160, 50])
    assert node.bb.get("reached") == pytest.approx([180.0, -160.0, 50.0], abs=1e-9)


def test_move_to_pose_without_planner_uses_the_arms_own_checks():
    rig = make_rig(planner=False)
    status, _ = run(MoveTo("go", to=[150, 100, 20]), rig)
    assert status is Status.SUCCESS
    assert np.allclose(rig.arm.pose()[:3, 3], [150, 100, 20])


@pytest.mark.parametrize("planner", [True, False])
def test_unreachable_target_fails_clearly_and_nothing_moves(planner):
    rig = make_rig(planner=planner)
    node = MoveTo("go", to=[0, 0, 0])
    status, _ = run(node, rig)
    assert status is Status.FAILURE
    assert "[0.0, 0.0, 0.0] mm" in node.feedback_message
    assert rig.arm.moves == []


def test_planner_refusal_is_a_failure_with_its_reason():
    rig = make_rig()
    node = MoveTo("go", to=[200, 0, -50])
    status, _ = run(node, rig)
    assert status is Status.FAILURE
    assert "refused" in node.feedback_message and "collision" in node.feedback_message
    assert rig.arm.moves == []


def test_a_failed_motion_fails_the_skill_with_the_drivers_error():
    rig = make_rig()
    rig.arm.fail_next_move = True
    node = MoveTo("go", to="home")
    status, _ = run(node, rig)
    assert status is Status.FAILURE and "link lost" in node.feedback_message


def test_bound_target_is_read_from_the_blackboard():
    rig = make_rig()
    node = MoveTo("go", to=Binding("target"))
    node.bb.register_key("target", access=armtree.api.behaviour.Access.WRITE)
    node.bb.set("target", [210.0, 20.0, 60.0])
    status, _ = run(node, rig)
    assert status is Status.SUCCESS and np.allclose(rig.arm.pose()[:3, 3], [210, 20, 60])


def test_bad_bound_target_fails_with_a_message():
    rig = make_rig()
    node = MoveTo("go", to=Binding("target"))
    node.bb.register_key("target", access=armtree.api.behaviour.Access.WRITE)
    node.bb.set("target", "nowhere")
    status, _ = run(node, rig)
    assert status is Status.FAILURE and "unknown place 'nowhere'" in node.feedback_message


def test_unknown_place_name_is_a_config_error_at_setup():
    rig = make_rig()
    with pytest.raises(armtree.ConfigError, match="unknown place 'kitchen'"):
        MoveTo("go", to="kitchen").setup(rig=rig, clock=rig.clock)


def test_halt_stops_the_arm_and_keeps_the_suction_on():
    rig = make_rig(ticks=20)
    rig.arm.suction = True
    node = MoveTo("go", to="garbage_bin")
    node.setup(rig=rig, clock=rig.clock)
    node.tick_once()
    rig.step(0.0)
    assert node.status is Status.RUNNING
    node.stop(Status.INVALID)
    assert rig.arm.stops >= 1 and rig.arm.suction is True
    assert not node.halting()  # the fake stops at once


def test_home_goes_to_the_models_home_joints():
    rig = make_rig()
    rig.arm.q = np.array([40.0, 150.0, 10.0])
    status, _ = run(Home("home"), rig)
    assert status is Status.SUCCESS and np.allclose(rig.arm.q, rig.arm.model.home)


def test_a_rig_without_an_arm_fails_with_a_message():
    rig = make_rig()
    rig.arm = None
    node = Home("home")
    node.setup(rig=rig, clock=rig.clock)
    node.tick_once()
    assert node.status is Status.FAILURE and "no arm" in node.feedback_message


def test_a_stalled_motion_times_out_and_stops_the_arm():
    rig = make_rig(ticks=10**6)  # the arm never reports the move done
    node = MoveTo("go", to="home", offset=[0, 0, 20])
    status, ticks = run(node, rig, max_ticks=1000)
    assert status is Status.FAILURE and "did not finish in time" in node.feedback_message
    assert rig.arm.stops >= 1
    assert ticks * 0.05 < 30.0


def test_time_the_process_was_suspended_is_not_held_against_a_motion():
    """Issue 32: a motion whose allowance ran out while the process was stopped (Ctrl-Z)
    is not a stalled arm; once the suspension is used up the stall is reported again."""
    rig = make_rig(ticks=10**6)
    suspended = {"s": 1e9}
    rig.arm.suspended_s = lambda since: suspended["s"]
    node = MoveTo("go", to="home", offset=[0, 0, 20])
    status, ticks = run(node, rig, max_ticks=1000)
    assert status is Status.RUNNING and rig.arm.stops == 0, node.feedback_message
    suspended["s"] = 0.0
    status, _ = run(node, rig, max_ticks=5)
    assert status is Status.FAILURE and "did not finish in time" in node.feedback_message


def test_home_on_the_reference_uses_the_arms_own_homing_and_repeats_it_until_homed():
    rig = make_rig()
    homings = []
    rig.arm.homed = False

    def home():
        homings.append(rig.clock.now())
        rig.arm.homed = len(homings) >= 2  # the first homing misses an end stop
        return rig.arm.move_joints(rig.arm.model.home)

    rig.arm.home = home
    rig.arm.q = np.array([30.0, 150.0, 20.0])
    status, _ = run(Home("home", reference=True), rig)
    assert status is Status.SUCCESS and len(homings) == 2
    assert np.allclose(rig.arm.q, rig.arm.model.home)


def test_home_on_the_reference_fails_when_the_arm_never_reports_homed():
    rig = make_rig()
    rig.arm.homed = False
    rig.arm.home = lambda: rig.arm.move_joints(rig.arm.model.home)
    node = Home("home", reference=True)
    status, _ = run(node, rig)
    assert status is Status.FAILURE and "did not report homed" in node.feedback_message
