"""search and clean_up on fake rigs (Showers 2016, appendix B)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from py_trees.common import Status
from test_skills_fakes import Marker, _clean_blackboard, make_rig, run  # noqa: F401

import armtree
from armtree.api.skill.survey import sweep_angles
from armtree.config.params import Binding
from armtree.plugins.skills.search import CleanUp, Search


def on_arc(deg, r=200.0, z=0.0):
    return np.array([r * math.cos(math.radians(deg)), r * math.sin(math.radians(deg)), z])


def test_sweep_goes_to_the_top_then_back_to_the_bottom_in_5_degree_steps():
    angles = sweep_angles(0.0, -100.0, 100.0, 5.0, 2)
    assert angles[:3] == [0.0, 5.0, 10.0]
    assert max(angles) == 100.0 and min(angles) == -100.0 and angles[-1] == -100.0
    assert len(angles) == 21 + 41  # back: 97.5, 92.5, ..., -97.5, -100


def test_the_way_back_looks_from_between_the_poses_of_the_way_out():
    angles = sweep_angles(0.0, -100.0, 100.0, 5.0, 3)
    out, back, again = angles[:21], angles[21:62], angles[62:]
    assert back[:2] == [97.5, 92.5] and back[-2:] == [-97.5, -100.0]
    gaps = [min(abs(b - o) for o in out) for b in back if 0 < b < 100]
    assert gaps and all(g == pytest.approx(2.5) for g in gaps)
    assert again[:2] == [-95.0, -90.0], "the third leg is on the first leg's grid"


@settings(deadline=None)  # a shared machine may stall any example
@given(
    start=st.floats(-150, 150),
    lo=st.floats(-120, 0),
    span=st.floats(1, 240),
    step=st.floats(0.5, 30),
    sweeps=st.integers(1, 4),
)
def test_sweep_stays_in_range_with_bounded_steps(start, lo, span, step, sweeps):
    hi = lo + span
    angles = np.array(sweep_angles(start, lo, hi, step, sweeps))
    assert np.all(angles >= lo - 1e-9) and np.all(angles <= hi + 1e-9)
    assert np.all(np.abs(np.diff(angles)) <= step + 1e-9)
    assert math.isclose(angles.max(), hi, abs_tol=1e-9)  # hi may be 0


def test_sweep_rejects_a_bad_step():
    with pytest.raises(ValueError):
        sweep_angles(0, -10, 10, 0, 1)


def test_search_finds_the_tag_and_outputs_its_base_position():
    rig = make_rig(workcell={"look_height_mm": 100.0}, markers=[Marker(1, on_arc(40.0))])
    node = Search("search", tag="duckybot", pose=Binding("duckybot_pose"))
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert np.allclose(node.bb.get("duckybot_pose"), on_arc(40.0), atol=1e-3)
    base_angle = rig.arm.q[0]
    assert 20.0 <= base_angle <= 45.0  # stopped where it first saw it


def test_search_fails_after_its_sweeps_without_the_tag():
    ring = {"radius_mm": 200.0, "step_deg": 20.0}
    rig = make_rig(
        workcell={"look_height_mm": 100.0, "survey": {"ring": ring}},
        markers=[Marker(1, on_arc(-170.0))],
    )
    node = Search("search", tag="duckybot", pose=Binding("p"))
    status, _ = run(node, rig)
    assert status is Status.FAILURE and "no 'duckybot' tag seen from" in node.feedback_message


def test_search_skips_refused_scan_poses():
    rig = make_rig(workcell={"look_height_mm": 100.0}, markers=[Marker(1, on_arc(60.0))])
    node = Search(
        "search", tag="duckybot", pose=Binding("p"), poses=[[0, 0, 0], "home", [100, 173, 100]]
    )
    status, _ = run(node, rig)
    assert status is Status.SUCCESS and np.allclose(node.bb.get("p"), on_arc(60.0), atol=1e-3)


def test_search_with_clean_up_bins_trash_on_the_way_then_finds_the_tag():
    trash = Marker(3, on_arc(15.0))
    bot = Marker(1, on_arc(70.0))
    rig = make_rig(workcell={"look_height_mm": 100.0}, markers=[trash, bot])
    node = Search("search", tag="duckybot", pose=Binding("p"), clean_up=True)
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert trash.dropped_at is not None
    assert np.allclose(trash.dropped_at[:2], [60, 230]) and trash.dropped_at[2] >= 40
    assert not rig.arm.suction and np.allclose(node.bb.get("p"), on_arc(70.0), atol=1e-3)


def test_search_without_clean_up_leaves_trash_alone():
    trash = Marker(3, on_arc(15.0))
    rig = make_rig(workcell={"look_height_mm": 100.0}, markers=[trash, Marker(1, on_arc(70.0))])
    status, _ = run(Search("search", tag="duckybot", pose=Binding("p")), rig)
    assert status is Status.SUCCESS and trash.dropped_at is None


def test_clean_up_clears_every_trash_marker_in_view():
    items = [Marker(2, np.array([205.0, 10.0, 0.0])), Marker(4, np.array([195.0, -15.0, 0.0]))]
    rig = make_rig(workcell={"look_height_mm": 100.0}, markers=items)
    rig.arm.q = np.array([0.0, 200.0, 120.0])
    node = CleanUp("clean", count=Binding("n"))
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert node.bb.get("n") == 2
    assert all(m.dropped_at is not None and np.allclose(m.dropped_at[:2], [60, 230]) for m in items)
    assert np.allclose(rig.arm.pose()[:3, 3], [200, 0, 120])  # back where it looked from


def test_clean_up_leaves_trash_that_will_not_come_away_after_its_attempts():
    rig = make_rig(
        workcell={"look_height_mm": 100.0}, markers=[Marker(2, np.array([205.0, 10.0, 0.0]))]
    )
    rig.world.grip = lambda tool: None
    rig.arm.q = np.array([0.0, 200.0, 120.0])
    node = CleanUp("clean", attempts=2, count=Binding("n"))
    status, _ = run(node, rig)
    assert status is Status.SUCCESS
    assert node.bb.get("n") == 0
    assert "0 trash carried" in node.feedback_message
    assert "marker 2: still there after 2 tries" in node.feedback_message


def test_clean_up_fails_after_max_items_carries():
    items = [Marker(i, np.array([200.0, -50.0 + 10 * i, 0.0])) for i in (2, 3, 4)]
    rig = make_rig(workcell={"look_height_mm": 100.0}, markers=items)
    rig.arm.q = np.array([0.0, 200.0, 120.0])
    node = CleanUp("clean", max_items=2)
    status, _ = run(node, rig)
    assert (
        status is Status.FAILURE
        and "trash still in view after 2 trash carried" in node.feedback_message
    )


def test_search_leaves_unreachable_trash_and_finds_the_tag():
    trash = Marker(3, np.append(on_arc(15.0)[:2], -100.0))  # below the arm's reach
    rig = make_rig(workcell={"look_height_mm": 100.0}, markers=[trash, Marker(1, on_arc(70.0))])
    node = Search("search", tag="duckybot", pose=Binding("p"), clean_up=True)
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert trash.dropped_at is None and not trash.held
    assert "marker 3: descend to" in node.feedback_message and "refused" in node.feedback_message


def test_search_needs_a_camera():
    rig = make_rig(camera=False)
    node = Search("search", tag="duckybot", pose=Binding("p"))
    status, _ = run(node, rig)
    assert status is Status.FAILURE and "no camera" in node.feedback_message


def test_clean_up_ignores_trash_already_in_the_bin():
    in_bin = Marker(2, np.array([70.0, 215.0, 0.0]))
    rig = make_rig(workcell={"look_height_mm": 100.0}, markers=[in_bin])
    rig.arm.q = np.array([72.0, 225.0, 120.0])  # camera over the bin
    node = CleanUp("clean", count=Binding("n"))
    status, _ = run(node, rig)
    assert status is Status.SUCCESS and node.bb.get("n") == 0
    assert rig.tracker.calls >= 1 and in_bin.dropped_at is None and not rig.arm.moves


def test_clean_up_with_no_bin_radius_takes_the_same_trash():
    in_bin = Marker(2, np.array([70.0, 215.0, 0.0]))
    rig = make_rig(workcell={"look_height_mm": 100.0}, markers=[in_bin])
    rig.arm.q = np.array([72.0, 225.0, 120.0])
    status, _ = run(CleanUp("clean", bin_radius_mm=0.0), rig)
    assert status is Status.SUCCESS and in_bin.dropped_at is not None


def test_search_on_a_profile_without_a_survey_region_says_what_to_add():
    rig = make_rig(workcell={"survey": None})
    node = Search("search", tag="duckybot", pose=Binding("p"))
    with pytest.raises(
        armtree.ConfigError, match=r"needs workcell\.survey in the hardware profile"
    ):
        node.setup(rig=rig, clock=rig.clock)
    assert rig.arm.moves == []


def test_clean_up_spreads_its_drops_across_a_bin_the_profile_describes():
    items = [Marker(2, np.array([205.0, 10.0, 0.0])), Marker(4, np.array([195.0, -15.0, 0.0]))]
    bins = {"garbage_bin": {"size_mm": [74.0, 74.0], "rim_z_mm": 20.0}}
    rig = make_rig(workcell={"look_height_mm": 100.0, "bins": bins}, markers=items)
    rig.arm.q = np.array([0.0, 200.0, 120.0])
    node = CleanUp("clean", count=Binding("n"))
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert node.bb.get("n") == 2
    a, b = (m.dropped_at for m in items)
    # both inside the bin, a marker's diagonal apart: side by side, not one on the other
    assert all(np.all(np.abs(p[:2] - [60.0, 230.0]) <= 37.0) for p in (a, b))
    assert np.linalg.norm(a[:2] - b[:2]) >= 25.0 * np.sqrt(2.0)
