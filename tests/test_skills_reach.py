"""Reachable stand-ins for wanted tool positions, and skills using them on a small workspace."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from py_trees.common import Status
from test_skills_fakes import CylModel, Marker, _clean_blackboard, make_rig, run  # noqa: F401

from armtree.api.skill.reach import highest_reachable, nearest_reachable, reachable
from armtree.config.params import Binding
from armtree.plugins.skills.pick import Pick
from armtree.plugins.skills.search import Search


def test_reachable_is_batched():
    model = CylModel()
    pts = np.array([[200.0, 0.0, 0.0], [0.0, 0.0, 0.0], [200.0, 0.0, 500.0]])
    assert reachable(model, pts).tolist() == [True, False, False]


def test_highest_reachable_stops_at_the_height_limit():
    model = CylModel()  # height limit 220 mm
    best = highest_reachable(model, np.array([200.0, 0.0, 150.0]), 150.0, 300.0)
    assert np.allclose(best, [200.0, 0.0, 220.0])
    assert highest_reachable(model, np.array([0.0, 0.0, 0.0]), 0.0, 50.0) is None


@settings(max_examples=30)
@given(x=st.floats(-400, 400), y=st.floats(-400, 400), z=st.floats(-200, 400))
def test_nearest_reachable_is_reachable_and_no_farther_than_needed(x, y, z):
    model = CylModel()
    target = np.array([x, y, z])
    near = nearest_reachable(model, target, span=400.0, step=4.0)
    if near is None:
        return
    assert reachable(model, near)
    # clamping reach and height to the limits is reachable too (when the angle is): not beaten by far
    r = np.clip(np.hypot(x, y), 80, 320)
    a = np.arctan2(y, x)
    clamp = np.array([r * np.cos(a), r * np.sin(a), np.clip(z, -60, 220)])
    if reachable(model, clamp):
        assert np.linalg.norm(near - target) <= np.linalg.norm(clamp - target) + 4.0 * 1.5


def test_pick_with_an_approach_above_the_workspace_clamps_it():
    rig = make_rig([Marker(0, np.array([185.0, -155.0, 190.0]))])
    rig.arm.q = np.array([-40.0, 240.0, 200.0])
    node = Pick("pick", tag="ducky", **{"from": [185.0, -155.0, 190.0]}, approach_mm=100.0)
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert rig.world.held is not None and np.isclose(rig.arm.pose()[2, 3], 220.0)


def test_search_arc_outside_the_workspace_is_pulled_into_it():
    rig = make_rig(
        [Marker(1, np.array([300.0, 0.0, 0.0]))],
        workcell={"survey": {"ring": {"radius_mm": 400.0}}},
    )
    node = Search("search", tag="duckybot", pose=Binding("p"))
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert np.isclose(np.hypot(*rig.arm.pose()[:2, 3]), 320.0, atol=2.0)
