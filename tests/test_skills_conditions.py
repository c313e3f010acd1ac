"""The conditions reactive trees check every tick, on fake rigs: instant, never moving."""

import numpy as np
import py_trees
import pytest
from py_trees.common import Status
from test_skills_fakes import PLACES, TICK, Marker, _clean_blackboard, make_rig  # noqa: F401

from armtree.api.rig import ToolState
from armtree.config.params import Binding
from armtree.plugins.skills.conditions import (
    ArmIdle,
    AtPlace,
    Holding,
    Misplaced,
    TagNear,
    TagVisible,
)
from armtree.runtime.resources import Resources


def tick(node, rig, ticks=1):
    """Tick ``node`` alone ``ticks`` times (the clock advancing between), its last status."""
    tree = py_trees.trees.BehaviourTree(node)
    tree.setup(rig=rig, clock=rig.clock, runtime=getattr(rig, "runtime", None))
    for n in range(ticks):
        if n:
            rig.clock.advance(TICK)
            rig.step(rig.clock.now())
        tree.tick()
    return node.status


def below_camera(rig, dx=0.0, dy=0.0):
    """A point on the table (z = 0) under the fake camera, offset by dx, dy mm."""
    cam = rig.arm.actual_pose() @ rig.camera.extrinsics
    return np.array([cam[0, 3] + dx, cam[1, 3] + dy, 0.0])


def test_tag_visible_writes_the_nearest_marker_and_fails_when_none_is_in_view():
    rig = make_rig()
    rig.world.markers = {3: Marker(3, below_camera(rig)), 2: Marker(2, below_camera(rig, 20))}
    rig.clock.advance(TICK)
    node = TagVisible("t", tag="trash", pose=Binding("p"), marker=Binding("m"))
    assert tick(node, rig) is Status.SUCCESS, node.feedback_message
    assert node.bb.get("m") in (2, 3) and len(node.bb.get("p")) == 3
    rig.world.markers = {}
    rig.clock.advance(1.0)
    assert tick(TagVisible("t2", tag="trash"), rig) is Status.FAILURE


def test_tag_visible_leaves_out_skipped_markers_and_those_near_a_place():
    rig = make_rig()
    rig.world.markers = {3: Marker(3, below_camera(rig))}
    rig.clock.advance(TICK)
    node = TagVisible("t", tag="trash", skip=Binding("skip"))
    py_trees.blackboard.Blackboard.set("/skip", [3])
    assert tick(node, rig) is Status.FAILURE
    spot = below_camera(rig).tolist()
    assert tick(TagVisible("t2", tag="trash", ignore_near=spot), rig) is Status.FAILURE
    assert tick(TagVisible("t3", tag="trash", ignore_near="garbage_bin"), rig) is Status.SUCCESS


def test_a_condition_ticked_every_tick_reads_a_few_frames_a_second_not_every_frame():
    rig = make_rig()
    rig.world.markers = {3: Marker(3, below_camera(rig))}
    rig.clock.advance(TICK)
    node = TagVisible("t", tag="trash", max_age_s=0.3)
    assert tick(node, rig, ticks=40) is Status.SUCCESS  # 2 s of ticks at 20 Hz
    assert rig.tracker.calls <= 8


def test_tag_near_is_about_distance_from_the_place():
    rig = make_rig()
    spot = below_camera(rig)
    rig.world.markers = {1: Marker(1, spot + [25.0, 0.0, 0.0])}
    rig.clock.advance(TICK)
    near = TagNear("n", tag="duckybot", near=spot.tolist(), radius_mm=30.0, pose=Binding("p"))
    assert tick(near, rig) is Status.SUCCESS
    assert np.allclose(near.bb.get("p"), spot + [25, 0, 0], atol=1e-6)
    far = TagNear("f", tag="duckybot", near=spot.tolist(), radius_mm=20.0)
    assert tick(far, rig) is Status.FAILURE and "within 20 mm" in far.feedback_message


def test_misplaced_names_the_marker_and_the_place_its_role_belongs():
    rig = make_rig(workcell={"sort": {"trash": "garbage_bin"}})
    rig.world.markers = {2: Marker(2, below_camera(rig)), 0: Marker(0, below_camera(rig, 10))}
    rig.clock.advance(TICK)
    node = Misplaced("m", role=Binding("role"), place=Binding("place"), marker=Binding("mid"))
    assert tick(node, rig) is Status.SUCCESS, node.feedback_message
    assert (node.bb.get("role"), node.bb.get("place"), node.bb.get("mid")) == (
        "trash",
        "garbage_bin",
        2,
    )
    rig.places["garbage_bin"] = below_camera(rig).tolist()  # now the trash is where it belongs
    assert tick(Misplaced("m2"), rig) is Status.FAILURE


def test_holding_follows_the_tool_report():
    rig = make_rig()
    assert tick(Holding("h"), rig) is Status.FAILURE
    rig.arm.suction = True
    node = Holding("h2", tag="ducky")
    assert tick(node, rig) is Status.SUCCESS
    assert "cannot look under it" in node.feedback_message  # eye-in-hand: the report only


def test_a_gripper_angle_beside_a_suction_cup_is_not_a_grip(monkeypatch):
    # The Dobot V1.0 reports a gripper angle (0.0) in every status frame whatever is
    # mounted; with its suction cup and the pump off, that is no grip.
    rig = make_rig()
    monkeypatch.setattr(type(rig.arm), "tool", property(lambda arm: ToolState(arm.suction, 0.0)))
    node = Holding("h", tag="ducky")
    assert tick(node, rig) is Status.FAILURE and "not gripping" in node.feedback_message
    rig.arm.suction = True
    assert tick(Holding("h2", tag="ducky"), rig) is Status.SUCCESS
    rig.arm.tool_kind = "gripper"  # a real gripper: 0.0 is its closed end (grip_closed)
    rig.arm.suction = False
    assert tick(Holding("h3", tag="ducky"), rig) is Status.SUCCESS


def test_holding_eye_to_hand_fails_when_the_marker_is_seen_away_from_the_tool():
    rig = make_rig(mount="eye_to_hand")
    rig.arm.suction = True
    rig.world.markers = {0: Marker(0, np.array([150.0, 0.0, 0.0]))}  # on the table, in view
    rig.clock.advance(TICK)
    node = Holding("h", tag="ducky")
    assert tick(node, rig) is Status.FAILURE and "from the tool" in node.feedback_message


def test_at_place_measures_the_tool_from_its_joints():
    rig = make_rig()
    assert tick(AtPlace("a", place="home"), rig) is Status.SUCCESS  # the fakes start at home
    node = AtPlace("b", place="garbage_bin", tolerance_mm=5.0)
    assert (
        tick(node, rig) is Status.FAILURE
        and "mm from [60.0, 230.0, 40.0] mm" in node.feedback_message
    )
    assert PLACES["home"] == [200.0, 0.0, 80.0]


def test_arm_idle_asks_who_owns_the_arm():
    class Runtime:
        resources = Resources()

    rig = make_rig()
    rig.runtime = Runtime()
    assert tick(ArmIdle("idle"), rig) is Status.SUCCESS
    mover = py_trees.behaviours.Running("mover")
    mover.tick_once()
    Runtime.resources.claim(mover, ["arm"])
    node = ArmIdle("idle2")
    assert tick(node, rig) is Status.FAILURE and "mover has the arm" in node.feedback_message


def test_conditions_never_move_the_arm():
    rig = make_rig()
    rig.world.markers = {3: Marker(3, below_camera(rig))}
    for node in (TagVisible("t", tag="trash"), Holding("h"), AtPlace("a", place="home")):
        tick(node, rig, ticks=5)
    assert rig.arm.moves == [] and rig.arm.stops == 0


@pytest.mark.parametrize("node", [TagVisible("t", tag="trash"), Misplaced("m")])
def test_camera_conditions_fail_saying_the_rig_has_no_camera(node):
    rig = make_rig(camera=False)
    assert tick(node, rig) is Status.FAILURE and "has no camera" in node.feedback_message
