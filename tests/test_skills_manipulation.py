"""pick and place on fake rigs: locating by tag, gripping, verifying, releasing."""

import re

import numpy as np
import pytest
from py_trees.common import Status
from test_skills_fakes import Marker, _clean_blackboard, make_rig, run  # noqa: F401

from armtree.config.params import Binding
from armtree.plugins.skills.pick import Grasp, Pick
from armtree.plugins.skills.place import Place


def ducky(at=(185.0, -155.0, 0.0)):
    return Marker(0, np.array(at, dtype=float))


def test_pick_locates_the_tag_near_the_place_and_holds_it():
    rig = make_rig([ducky()])
    node = Pick("pick", tag="ducky", **{"from": "ducky_pickup"}, pose=Binding("picked"))
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert rig.world.held is not None and rig.world.held.id == 0
    assert rig.arm.suction
    assert np.allclose(node.bb.get("picked"), [185, -155, 0], atol=1e-6)
    assert rig.arm.pose()[2, 3] > 50  # lifted


def test_pick_fails_when_the_tag_stays_behind_and_lets_go_on_purpose():
    rig = make_rig([ducky()])
    rig.world.grip = lambda tool: None  # the cup does not hold
    node = Pick("pick", tag="ducky", **{"from": "ducky_pickup"}, skip=Binding("skipped"))
    node.bb.set("skipped", [], overwrite=True)
    status, _ = run(node, rig)
    assert status is Status.FAILURE and "is still at" in node.feedback_message
    assert "mm from where it was gripped" in node.feedback_message
    assert not rig.arm.suction  # nothing left half held
    assert node.bb.get("skipped") == [0]


def test_pick_finds_a_ducky_40_mm_from_its_place_by_looking_around():
    place = np.array([180.0, -160.0, 0.0])  # ducky_pickup of the fakes
    rig = make_rig([ducky(place + [0.0, 40.0, 0.0])], workcell={"look_height_mm": 60.0})
    node = Pick("pick", tag="ducky", **{"from": "ducky_pickup"}, pose=Binding("picked"))
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert rig.world.held is not None and rig.world.held.id == 0
    assert np.allclose(node.bb.get("picked"), place + [0, 40, 0], atol=1e-6)


def test_pick_at_an_empty_spot_fails_saying_where_it_looked_and_never_goes_down():
    rig = make_rig([ducky((100.0, 200.0, 0.0))])
    node = Pick("pick", tag="ducky", **{"from": "ducky_pickup"})
    status, _ = run(node, rig)
    assert status is Status.FAILURE
    assert "no 'ducky' tag within 80 mm of [180.0, -160.0, 0.0] mm" in node.feedback_message
    looks = int(re.search(r"looked from (\d+) camera poses", node.feedback_message).group(1))
    assert looks >= 7  # over the place, then a ring around it
    assert not rig.arm.suction and rig.world.held is None
    assert min(rig.arm.model.position(q)[2] for q in rig.arm.moves) > 5.0  # never at the tag


def test_pick_of_a_tag_without_a_camera_fails_and_says_how_to_pick_blind():
    rig = make_rig([ducky((180.0, -160.0, 0.0))], camera=False)
    node = Pick("pick", tag="ducky", **{"from": "ducky_pickup"})
    status, _ = run(node, rig)
    assert status is Status.FAILURE and "needs a camera" in node.feedback_message
    assert "with at:" in node.feedback_message and rig.arm.moves == []


def test_untagged_pick_at_a_place_is_an_explicit_choice_reported_unverified():
    rig = make_rig([ducky((180.0, -160.0, 0.0))], camera=False)
    node = Pick("pick", at="ducky_pickup")
    status, _ = run(node, rig)
    assert status is Status.SUCCESS and rig.world.held.id == 0
    assert node.feedback_message.startswith("unverified: ")


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"tag": "ducky", "at": "ducky_pickup"}, "not both"),
        ({"from": "ducky_pickup"}, "give tag"),
        ({}, "give tag"),
    ],
)
def test_pick_needs_exactly_one_of_a_tag_or_a_blind_place(params, message):
    with pytest.raises(ValueError, match=message):
        Pick("pick", **params)


def holding_over_a_duckybot():
    """A rig holding the ducky (marker 0), a Duckybot's marker at [225, 60, 10] mm."""
    bot = Marker(1, np.array([225.0, 60.0, 10.0]))
    held = Marker(0, np.zeros(3), held=True)
    rig = make_rig([bot, held], workcell={"release_offset_mm": 30.0})
    rig.world.held = held
    rig.arm.suction = True
    return rig, held


def test_place_on_a_tag_uses_its_fresh_position_and_checks_the_object_is_on_it():
    rig, held = holding_over_a_duckybot()
    node = Place("place", at=[210.0, 50.0, 10.0], tag="duckybot", object="ducky")
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert not rig.arm.suction and rig.world.held is None
    assert np.allclose(held.dropped_at, [225, 60, 40], atol=1e-6)
    assert "0 mm from the target" in node.feedback_message


def test_place_fails_with_the_measured_distance_when_the_object_lands_off_the_target():
    rig, held = holding_over_a_duckybot()
    release = rig.world.release

    def slide_off(tool):
        release(tool)
        held.position = held.position + [35.0, 0.0, -30.0]  # it slid off onto the table

    rig.world.release = slide_off
    node = Place("place", at=[210.0, 50.0, 10.0], tag="duckybot", object="ducky")
    status, _ = run(node, rig)
    assert status is Status.FAILURE
    assert "35.0 mm from [225.0, 60.0, 10.0] mm" in node.feedback_message
    assert "not on the target (tolerance 20 mm)" in node.feedback_message


def test_place_without_its_tag_in_view_fails_and_keeps_holding():
    held = Marker(0, np.zeros(3), held=True)
    rig = make_rig([held, Marker(1, np.array([100.0, 200.0, 0.0]))])
    rig.world.held = held
    rig.arm.suction = True
    node = Place("place", at=[210.0, 50.0, 10.0], tag="duckybot")
    status, _ = run(node, rig)
    assert status is Status.FAILURE and "no 'duckybot' tag within 80 mm" in node.feedback_message
    assert "still holding" in node.feedback_message
    assert rig.arm.suction and rig.world.held is held  # nothing released


def test_place_at_a_named_place_without_a_tag_lets_go_there():
    held = Marker(2, np.zeros(3), held=True)
    rig = make_rig([held])
    rig.world.held = held
    rig.arm.suction = True
    node = Place("drop", at="garbage_bin", object="trash")
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert np.allclose(held.dropped_at, [60, 230, 40])


@pytest.mark.parametrize("marker", [None, 2])
def test_place_checks_the_marker_it_let_go_not_the_nearest_of_its_role(marker):
    # eye-to-hand: the dropped trash is hidden in the bin, other trash lies on the table
    held = Marker(2, np.zeros(3), held=True)
    rig = make_rig([held, Marker(3, np.array([180.0, 150.0, 0.0]))], mount="eye_to_hand")
    rig.world.held = held
    rig.arm.suction = True
    release = rig.world.release

    def into_the_bin(tool):
        release(tool)
        held.position = np.array([60.0, 230.0, 1e6])  # out of the camera's sight

    rig.world.release = into_the_bin
    node = Place("drop", at="garbage_bin", object="trash", marker=marker)
    status, _ = run(node, rig)
    if marker is None:  # the other trash, 130 mm off, is taken for the one let go
        assert status is Status.FAILURE and "not at the target" in node.feedback_message
    else:
        assert status is Status.SUCCESS, node.feedback_message
        assert "'trash' tag is not in view" in node.feedback_message


def test_place_without_an_object_tag_says_it_did_not_check():
    held = Marker(2, np.zeros(3), held=True)
    rig = make_rig([held])
    rig.world.held = held
    rig.arm.suction = True
    node = Place("drop", at="garbage_bin")
    status, _ = run(node, rig)
    assert status is Status.SUCCESS and node.feedback_message.startswith("unverified: ")


class RunLog:
    """Collects the events a skill writes to the run log."""

    enabled = True

    def __init__(self):
        self.events = []

    def event(self, tick, t, event, **data):
        self.events.append((event, data))


class Runtime:
    """What a skill reads of the runtime: its log and tick count."""

    def __init__(self):
        self.log = RunLog()
        self.tick_count = 0

    def claim(self, behaviour, names):
        return None


def pick_until(rig, runtime, until, ticks=200):
    """A pick of the ducky, ticked until ``until(rig)`` holds (or ``ticks`` ran out)."""
    node = Pick("pick", tag="ducky", **{"from": "ducky_pickup"})
    node.setup(rig=rig, clock=rig.clock, runtime=runtime)
    for _ in range(ticks):
        node.tick_once()
        rig.clock.advance(0.05)
        rig.step(rig.clock.now())
        if until(rig):
            break
    return node


def test_halted_pick_while_holding_keeps_the_object_and_logs_it():
    rig = make_rig([ducky()], ticks=2)
    runtime = Runtime()
    node = pick_until(
        rig, runtime, lambda r: r.world.held is not None and r.arm._motion is not None
    )
    assert rig.world.held is not None
    node.stop(Status.INVALID)
    rig.step(rig.clock.now())
    assert rig.arm.suction and rig.world.held is not None and rig.arm.stops >= 1
    halted = [data for event, data in runtime.log.events if event == "halted"]
    assert halted and halted[0]["tool"] == "suction on, holding what it holds"
    assert halted[0]["step"].startswith("lift")


def test_halted_pick_before_the_grip_holds_nothing_and_logs_it():
    rig = make_rig([ducky()], ticks=2)
    runtime = Runtime()
    node = pick_until(rig, runtime, lambda r: False, ticks=10)
    node.stop(Status.INVALID)
    assert not rig.arm.suction and rig.world.held is None
    halted = [data for event, data in runtime.log.events if event == "halted"]
    assert halted and halted[0]["tool"] == "suction off, holding nothing"


def test_a_release_point_just_out_of_reach_moves_within_reach_by_a_few_mm():
    held = Marker(0, np.zeros(3), held=True)
    rig = make_rig([held])
    rig.world.held = held
    rig.arm.suction = True
    node = Place("drop", at=[326.0, 0.0, 20.0])  # the fake arm reaches r <= 320 mm
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert 314.0 <= np.hypot(*held.dropped_at[:2]) <= 320.0 + 1e-6
    far = Place("drop2", at=[345.0, 0.0, 20.0])
    rig.world.held, held.held, rig.arm.suction = held, True, True
    status, _ = run(far, rig)
    assert status is Status.FAILURE and "refused" in far.feedback_message


def test_a_failed_grasp_homes_the_arm_on_its_reference_when_asked():
    rig = make_rig([ducky((200.0, -50.0, 0.0))])
    rig.world.grip = lambda tool: None  # the cup does not hold
    homings = []
    rig.arm.home = lambda: homings.append(1) or rig.arm.move_joints(rig.arm.model.home)
    node = Grasp("g", at=[200.0, -50.0, 0.0], tag="ducky", rehome_on_failure=True)
    status, _ = run(node, rig)
    assert status is Status.FAILURE and "the grip failed" in node.feedback_message
    assert homings == [1] and np.allclose(rig.arm.q, rig.arm.model.home)


def test_the_place_check_looks_around_the_target_when_the_view_over_it_misses():
    rig, held = holding_over_a_duckybot()
    release = rig.world.release

    def blind_then_release(tool):
        release(tool)
        rig.tracker.blind_frames = 2  # the two frames over the target see nothing

    rig.world.release = blind_then_release
    node = Place("place", at=[210.0, 50.0, 10.0], tag="duckybot", object="ducky")
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert "0 mm from the target" in node.feedback_message


def test_a_marker_turned_across_the_base_direction_is_gripped_farther_in():
    from armtree.plugins.skills.grip import edge_toward_base

    target = np.array([0.0, 200.0, -10.0])  # the base lies in -y
    assert edge_toward_base(target, 25.0, None) == pytest.approx(12.5)
    assert edge_toward_base(target, 25.0, 0.0) == pytest.approx(12.5)  # a side faces the base
    # turned 45 degrees a corner faces the base: the edge is half the diagonal away
    assert edge_toward_base(target, 25.0, np.pi / 4) == pytest.approx(12.5 * np.sqrt(2.0))


def held_release(bias, at=(200.0, 0.0, 0.0)):
    """Eye-to-hand: a ducky held at the tool centre, joints that lost steps by ``bias``
    (base deg, reach mm, height mm), let go at [200, 0, 0] mm."""
    from armtree.plugins.skills.held import HELD_KEY, Held
    from armtree.plugins.skills.place import Release

    held = Marker(0, np.array([at[0], at[1], 80.0]), held=True)
    rig = make_rig([held], mount="eye_to_hand")
    rig.world.held = held
    rig.arm.suction = True
    rig.arm.bias = np.asarray(bias, dtype=float)
    node = Release("let go", at=list(at), object="ducky", verify=False)
    # the grip a pick handed over: the marker at the tool centre
    node.bb.set(HELD_KEY, Held(np.array([0.0, 0.0, 0.0, 1.0]), None), overwrite=True)
    status, _ = run(node, rig)
    return status, node, rig, held


def test_a_held_marker_off_the_joints_moves_the_release_and_never_lowers_it():
    # steps lost: the tool is really 6 mm farther out and 8 mm lower than the joints say
    status, node, rig, held = held_release([0.0, 6.0, -8.0])
    assert status is Status.SUCCESS, node.feedback_message
    # let go where it was meant to land, not 8 mm lower (into what is under it)
    np.testing.assert_allclose(held.dropped_at, [200.0, 0.0, 0.0], atol=1.0)
    # a marker higher than the joints say is no reason to go lower
    status, node, rig, held = held_release([0.0, 0.0, 8.0])
    assert status is Status.SUCCESS and held.dropped_at[2] == pytest.approx(8.0, abs=1.0)


def test_joints_that_agree_with_the_held_marker_change_nothing():
    status, node, rig, held = held_release([0.0, 0.0, 0.0])
    assert status is Status.SUCCESS, node.feedback_message
    np.testing.assert_allclose(held.dropped_at, [200.0, 0.0, 0.0], atol=1e-6)


def test_a_correction_out_of_reach_fails_still_holding():
    # the tool is really 10 mm nearer the base: the corrected release lies past its reach
    status, node, rig, held = held_release([0.0, -10.0, 0.0], at=(315.0, 0.0, 0.0))
    assert status is Status.FAILURE
    assert "out of reach; still holding it" in node.feedback_message
    assert held.held and rig.arm.suction


def beside_a_ducky(dy, height=30.0, lifted=0.0):
    """A trash marker at [200, 0, 20] mm and a ``height`` mm tall ducky's marker ``dy`` mm
    beside it (``lifted`` mm off the table), and a tool whose 40 x 40 x 60 mm body rises
    from the tool centre."""
    from armtree.maths.motion.kinematics import LinkBox

    trash = Marker(2, np.array([200.0, 0.0, 20.0]))
    other = Marker(0, np.array([200.0, dy, height + lifted]))
    rig = make_rig(
        [trash, other],
        workcell={"marker_heights_mm": {"ducky": height, "trash": 20.0}},
    )
    body = np.eye(4)
    body[2, 3] = 30.0
    rig.arm.model.boxes = (LinkBox("cup", 0, (40.0, 40.0, 60.0), body),)
    return rig


def test_a_grip_whose_tool_would_hit_a_neighbour_moves_away_within_the_marker():
    rig = beside_a_ducky(38.0)  # the tool's side 21 mm out, the ducky's about 20 mm
    node = Pick("pick", tag="trash", **{"from": [200.0, 0.0, 20.0]})
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert rig.world.held is not None and rig.world.held.id == 2
    lowest = min(rig.arm.moves, key=lambda q: rig.arm.model.position(q)[2])
    grip = rig.arm.model.position(lowest)
    assert grip[2] == pytest.approx(20.0, abs=1e-6)
    assert np.hypot(grip[0] - 200.0, grip[1]) < 5.0  # still on the trash
    assert grip[1] < -0.5  # away from the ducky


def test_a_grip_that_cannot_clear_a_neighbour_is_refused_before_going_down():
    rig = beside_a_ducky(25.0)
    node = Pick("pick", tag="trash", **{"from": [200.0, 0.0, 20.0]}, skip=Binding("skipped"))
    node.bb.set("skipped", [], overwrite=True)
    status, _ = run(node, rig)
    assert status is Status.FAILURE
    assert "would hit the ducky (marker 0)" in node.feedback_message
    assert rig.world.held is None and not rig.arm.suction
    assert min(rig.arm.model.position(q)[2] for q in rig.arm.moves) > 30.0  # above its top
    assert node.bb.get("skipped") == [2]  # a clean-up moves on to other trash


def test_a_neighbour_lower_than_the_grip_is_no_obstacle():
    rig = beside_a_ducky(25.0, height=15.0)  # its top below the tool's body at the grip
    node = Pick("pick", tag="trash", **{"from": [200.0, 0.0, 20.0]})
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    lowest = min(rig.arm.moves, key=lambda q: rig.arm.model.position(q)[2])
    assert np.allclose(rig.arm.model.position(lowest), [200.0, 0.0, 20.0], atol=1e-6)


def test_a_neighbour_seen_off_the_table_is_no_obstacle():
    rig = beside_a_ducky(25.0, lifted=40.0)  # carried: it will not stand there
    node = Pick("pick", tag="trash", **{"from": [200.0, 0.0, 20.0]})
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
