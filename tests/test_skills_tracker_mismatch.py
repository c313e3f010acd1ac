"""A failed search says what the camera saw: marker-like shapes of another family, tags of
other roles, markers of no role, or nothing; and the trackers count those shapes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from py_trees.common import Status
from test_skills_fakes import Marker, _clean_blackboard, make_rig, run  # noqa: F401

from armtree.api.rig import Frame
from armtree.api.skill.eye import Tally
from armtree.config.params import Binding
from armtree.plugins.skills.pick import Pick
from armtree.plugins.skills.search import Search
from armtree.plugins.trackers import synthetic as syn
from armtree.plugins.trackers.aruco import ArucoTracker
from armtree.plugins.trackers.hamming import HammingTracker

K = syn.nominal_camera()


class CountingUnread:
    """A fake tracker's ``unread``: ``value``, and how often it was asked."""

    def __init__(self, value: int) -> None:
        self.value = value
        self.asked = 0

    def __get__(self, tracker, owner=None) -> int:
        self.asked += 1
        return self.value


def mismatched(rig, unread: int, family: str = "hamming") -> CountingUnread:
    """Make ``rig``'s fake tracker report ``unread`` shapes of no marker of ``family``."""
    counter = CountingUnread(unread)
    kind = type(rig.tracker)
    rig.tracker.__class__ = type("Mismatched", (kind,), {"unread": counter})
    rig.tracker.marker_family = family
    return counter


def test_a_pick_that_saw_shapes_of_another_family_says_so():
    rig = make_rig([])
    counter = mismatched(rig, 3)
    node = Pick("pick", tag="ducky", **{"from": "ducky_pickup"})
    status, _ = run(node, rig)
    assert status is Status.FAILURE
    assert "no 'ducky' tag within 80 mm of [180.0, -160.0, 0.0] mm (looked from" in (
        node.feedback_message
    )
    assert (
        "3 marker-like shapes in a frame decoded as nothing in family hamming: the markers "
        "may be of another family" in node.feedback_message
    )
    assert counter.asked >= 7, "every frame of the search, none of which showed the ducky"


def test_a_pick_that_saw_nothing_or_other_tags_says_what_it_saw():
    rig = make_rig([])
    node = Pick("pick", tag="ducky", **{"from": "ducky_pickup"})
    assert run(node, rig)[0] is Status.FAILURE
    assert "no marker in any of" in node.feedback_message
    # a trash marker and a marker of no role near the pick-up place, no ducky
    rig = make_rig(
        [Marker(2, np.array([180.0, -150.0, 0.0])), Marker(17, np.array([170.0, -165.0, 0.0]))]
    )
    node = Pick("pick", tag="ducky", **{"from": "ducky_pickup"})
    assert run(node, rig)[0] is Status.FAILURE
    assert "saw 'trash', markers 17 of no tag role" in node.feedback_message


def test_frames_that_show_the_tag_are_not_asked_for_unread_shapes():
    rig = make_rig([Marker(1, np.array([200.0 * math.cos(0.3), 200.0 * math.sin(0.3), 0.0]))])
    counter = mismatched(rig, 2)
    node = Search("search", tag="duckybot", pose=Binding("p"))
    assert run(node, rig)[0] is Status.SUCCESS
    frames = rig.tracker.calls
    assert 0 < counter.asked < frames


def test_a_search_that_never_saw_its_tag_says_what_it_saw():
    rig = make_rig(workcell={"look_height_mm": 100.0})
    mismatched(rig, 1, "4x4_50")
    node = Search("search", tag="duckybot", pose=Binding("p"))
    assert run(node, rig)[0] is Status.FAILURE
    assert "scan poses (1 marker-like shape in a frame decoded as nothing in family 4x4_50" in (
        node.feedback_message
    )


def test_tally_words():
    assert Tally(frames=12).describe("hamming") == "no marker in any of 12 frames"
    assert (
        Tally(frames=3, unread=1)
        .describe(None)
        .startswith("1 marker-like shape in a frame decoded as nothing in family of the tracker")
    )
    seen = Tally(frames=5, roles={"trash", "duckybot"}, unknown={40, 9})
    assert seen.describe("4x4_50") == "saw 'duckybot', 'trash', markers 9, 40 of no tag role"


def frame_of(generator: str, dictionary: str, ids: list[int]) -> Frame:
    placements = []
    for i, (x, y) in enumerate([(-60.0, -20.0), (0.0, 30.0), (60.0, -20.0)][: len(ids)]):
        rvec, tvec = syn.look_at_pose(400.0, 15.0 * i, 40.0 * i, (x, y))
        placements.append(syn.Placement(ids[i], 25.0, rvec, tvec))
    image, _ = syn.render_markers(
        generator,
        placements,
        K,
        dictionary=dictionary,
        effects=syn.Effects(noise=2.0, blur=0.6, seed=len(ids)),
        backdrop=syn.cluttered(seed=7),
    )
    return Frame(image, 0.0, K, np.zeros(5))


@pytest.mark.parametrize(
    ("printed", "reader", "unread"),
    [
        (("hamming", "4x4_50", [69937, 69975, 70026]), "4x4_50", 3),
        (("hamming", "4x4_50", [69937, 69975, 70026]), "apriltag_36h11", 3),
        (("aruco", "4x4_50", [3, 7]), "hamming", 2),
        (("aruco", "apriltag_36h11", [3, 7]), "hamming", 2),
        (("aruco", "apriltag_36h11", [3, 7]), "4x4_50", 2),
        (("aruco", "4x4_50", [3, 7]), "4x4_50", 0),
        (("aruco", "apriltag_36h11", [3, 7]), "apriltag_36h11", 0),
        (("hamming", "4x4_50", [69937, 69975, 70026]), "hamming", 0),
    ],
)
def test_trackers_count_the_markers_of_other_families_they_could_not_read(printed, reader, unread):
    generator, dictionary, ids = printed
    tracker = HammingTracker() if reader == "hamming" else ArucoTracker(reader)
    assert tracker.marker_family == reader
    dets = tracker.detect(frame_of(generator, dictionary, ids))
    same = reader == ("hamming" if generator == "hamming" else dictionary)
    assert sorted(d.id for d in dets) == (sorted(ids) if same else [])
    assert tracker.unread == unread
