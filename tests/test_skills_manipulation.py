"""pick and place on fake rigs: locating by tag, gripping, verifying, releasing."""

import numpy as np
from py_trees.common import Status
from test_skills_fakes import Marker, _clean_blackboard, make_rig, run  # noqa: F401

from armtree.params import Binding
from armtree.plugins.skills.manipulation import Pick, Place


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


def test_pick_fails_when_the_tag_stays_behind():
    rig = make_rig([ducky()])
    rig.world.grip = lambda tool: None  # the cup does not hold
    node = Pick("pick", tag="ducky", **{"from": "ducky_pickup"})
    status, _ = run(node, rig)
    assert status is Status.FAILURE and "still at" in node.feedback_message


def test_pick_without_a_camera_uses_the_place():
    rig = make_rig([ducky((180.0, -160.0, 0.0))], camera=False)
    node = Pick("pick", tag="ducky", **{"from": "ducky_pickup"})
    status, _ = run(node, rig)
    assert status is Status.SUCCESS and rig.world.held.id == 0


def test_pick_with_neither_place_nor_visible_tag_fails():
    rig = make_rig([])
    node = Pick("pick", tag="ducky")
    status, _ = run(node, rig)
    assert status is Status.FAILURE and "no 'ducky' tag in view" in node.feedback_message


def test_place_on_a_tag_uses_its_fresh_position_and_releases():
    bot = Marker(1, np.array([225.0, 60.0, 10.0]))
    held = Marker(0, np.zeros(3), held=True)
    rig = make_rig([bot, held], workcell={"release_offset_mm": 30.0})
    rig.world.held = held
    rig.arm.suction = True
    node = Place("place", at=[210.0, 50.0, 10.0], tag="duckybot")
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert not rig.arm.suction and rig.world.held is None
    assert np.allclose(held.dropped_at, [225, 60, 40], atol=1e-6)


def test_place_fails_when_the_tag_is_not_near_the_target():
    rig = make_rig([Marker(1, np.array([100.0, 200.0, 0.0]))])
    rig.arm.suction = True
    node = Place("place", at=[210.0, 50.0, 10.0], tag="duckybot", require_tag=True)
    status, _ = run(node, rig)
    assert status is Status.FAILURE and "no 'duckybot' tag within" in node.feedback_message
    assert rig.arm.suction  # nothing released


def test_place_without_its_tag_in_view_uses_the_given_pose():
    held = Marker(0, np.zeros(3), held=True)
    rig = make_rig(
        [held, Marker(1, np.array([100.0, 200.0, 0.0]))], workcell={"release_offset_mm": 30.0}
    )
    rig.world.held = held
    rig.arm.suction = True
    node = Place("place", at=[210.0, 50.0, 10.0], tag="duckybot")
    status, _ = run(node, rig)
    assert status is Status.SUCCESS and np.allclose(held.dropped_at, [210, 50, 40])


def test_place_at_a_named_place_without_a_tag():
    held = Marker(2, np.zeros(3), held=True)
    rig = make_rig([held])
    rig.world.held = held
    rig.arm.suction = True
    status, _ = run(Place("drop", at="garbage_bin"), rig)
    assert status is Status.SUCCESS and np.allclose(held.dropped_at, [60, 230, 40])


def test_halted_pick_while_holding_keeps_the_object():
    rig = make_rig([ducky()], ticks=2)
    node = Pick("pick", tag="ducky", **{"from": "ducky_pickup"})
    node.setup(rig=rig, clock=rig.clock)
    for _ in range(200):
        node.tick_once()
        rig.clock.advance(0.05)
        rig.step(rig.clock.now())
        if rig.world.held is not None and rig.arm._motion is not None:
            break
    assert rig.world.held is not None
    node.stop(Status.INVALID)
    rig.step(rig.clock.now())
    assert rig.arm.suction and rig.world.held is not None and rig.arm.stops >= 1
