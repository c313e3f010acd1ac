"""The fine-grained actions on fake rigs: look, approach, grasp, release, sweep, search_step."""

import dataclasses
import math

import numpy as np
import py_trees
import pytest
from py_trees.common import Status
from test_skills_fakes import TICK, Marker, _clean_blackboard, make_rig, run  # noqa: F401

from armtree.config.params import Binding
from armtree.plugins.skills.held import HELD_KEY
from armtree.plugins.skills.pick import Grasp
from armtree.plugins.skills.place import Release
from armtree.plugins.skills.steps import Approach, LookFor, SearchStep, Sweep

#: The fake rig's survey: a ring of r = 200 mm, 20 degree steps from -100 to 100 degrees.
RING = {"survey": {"ring": {"radius_mm": 200.0, "range_deg": [-100, 100], "step_deg": 20}}}


def on_ring(deg, r=200.0):
    return np.array([r * math.cos(math.radians(deg)), r * math.sin(math.radians(deg)), 0.0])


def heading(rig):
    tool = rig.arm.pose()[:3, 3]
    return math.degrees(math.atan2(tool[1], tool[0]))


def test_look_finds_the_tag_around_a_place_and_writes_pose_and_marker():
    rig = make_rig([Marker(0, np.array([180.0, -140.0, 0.0]))])
    node = LookFor("look", tag="ducky", near="ducky_pickup", pose=Binding("p"), marker=Binding("m"))
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert np.allclose(node.bb.get("p"), [180, -140, 0], atol=1e-6) and node.bb.get("m") == 0
    missing = LookFor("look2", tag="duckybot", near="ducky_pickup")
    status, _ = run(missing, rig)
    assert status is Status.FAILURE and "no 'duckybot' tag within 80 mm" in missing.feedback_message


def test_approach_hovers_over_the_point():
    rig = make_rig()
    node = Approach("a", to=[200.0, 50.0, 0.0], height_mm=40.0)
    status, _ = run(node, rig)
    assert status is Status.SUCCESS
    assert np.allclose(rig.arm.pose()[:3, 3], [200, 50, 40], atol=1e-6)


def test_grasp_then_release_move_the_object_and_check_both_ends():
    ducky = Marker(0, np.array([200.0, -50.0, 0.0]))
    rig = make_rig([ducky], workcell={"look_height_mm": 100.0})
    grasp = Grasp("g", at=[200.0, -50.0, 0.0], tag="ducky", marker=Binding("m"))
    py_trees.blackboard.Blackboard.set("/m", 0)
    status, _ = run(grasp, rig)
    assert status is Status.SUCCESS, grasp.feedback_message
    assert rig.world.held is ducky and "spot is empty" in grasp.feedback_message
    # the grip goes to the release on the blackboard: the marker where the tool touched it
    held = py_trees.blackboard.Blackboard.get(HELD_KEY)
    # the grip's height over the table: the fakes grip at the marker (offset 0), table z 0
    assert held.hang_mm == pytest.approx(0.0, abs=1e-9)
    tool = rig.arm.model.fk(rig.arm.model.ik(np.array([200.0, -50.0, held.hang_mm])))
    np.testing.assert_allclose((tool @ held.marker_in_tool)[:3], [200.0, -50.0, 0.0], atol=1e-6)
    added = vars(rig).keys() - {f.name for f in dataclasses.fields(rig)} - {"world"}
    assert not added, f"attributes set on the rig: {added}"
    release = Release("r", at=[200.0, 60.0, 0.0], object="ducky")
    status, _ = run(release, rig)
    assert status is Status.SUCCESS, release.feedback_message
    assert rig.world.held is None and np.allclose(ducky.position, [200, 60, 0], atol=1e-6)
    assert not py_trees.blackboard.Blackboard.exists(HELD_KEY), "taken by the release"


def test_sweep_finds_the_tag_from_the_survey():
    rig = make_rig([Marker(1, on_ring(60.0))], workcell=RING)
    node = Sweep("s", tag="duckybot", pose=Binding("p"))
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert np.allclose(node.bb.get("p"), on_ring(60.0), atol=1e-6)


def test_a_halted_sweep_goes_back_to_its_scan_pose_and_resumes_from_there():
    rig = make_rig([], workcell=RING)
    node = Sweep("s", tag="duckybot")
    tree = py_trees.trees.BehaviourTree(node)
    tree.setup(rig=rig, clock=rig.clock)
    for _ in range(30):  # part way along the ring
        tree.tick()
        rig.clock.advance(TICK)
        rig.step(rig.clock.now())
    where = node.feedback_message
    at = node._next
    assert where.startswith("scan to") and at > 0
    node.stop(Status.INVALID)  # preempted (trash to clear)
    rig.arm.move_joints(np.array([-90.0, 200.0, 80.0]))  # the arm went elsewhere meanwhile
    for _ in range(5):
        rig.step(rig.clock.now())
    tree.tick()
    assert node.feedback_message == where and node._next == at
    for _ in range(5):
        rig.clock.advance(TICK)
        rig.step(rig.clock.now())
        tree.tick()
    target = node._points[at]
    assert abs(heading(rig) - math.degrees(math.atan2(target[1], target[0]))) < 15.0


def test_a_sweep_without_a_tag_covers_the_region_and_succeeds():
    rig = make_rig([], workcell=RING)
    node = Sweep("s", sweeps=1)
    status, _ = run(node, rig)
    assert status is Status.SUCCESS and "covered the survey region" in node.feedback_message
    assert heading(rig) > 90.0  # ended at the far end of the ring


def test_search_step_moves_one_scan_pose_per_run_and_goes_on_from_there():
    rig = make_rig([Marker(1, on_ring(40.0))], workcell=RING)
    node = SearchStep("step", tag="duckybot", steps=1)
    tree = py_trees.trees.BehaviourTree(node)
    tree.setup(rig=rig, clock=rig.clock)  # once, as a run does
    headings = []
    for _ in range(4):
        for _ in range(200):
            tree.tick()
            if node.status is not Status.RUNNING:
                break
            rig.clock.advance(TICK)
            rig.step(rig.clock.now())
        status = node.status
        headings.append(round(heading(rig)))
        if status is Status.SUCCESS:
            break
    assert status is Status.SUCCESS
    assert len(headings) >= 2 and headings == sorted(headings)  # one pose further each run
