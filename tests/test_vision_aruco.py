"""The aruco tracker: dictionaries by name, detector parameters, preprocessing, poses."""

import numpy as np
import pytest

from armtree.api.clock import VirtualClock
from armtree.api.rig import Frame, RigContext
from armtree.errors import ConfigError
from armtree.plugins.trackers import synthetic as syn
from armtree.plugins.trackers.aruco import (
    ArucoTracker,
    aruco_factory,
    detector_parameters,
)
from armtree.plugins.trackers.common import TagRoles
from armtree.plugins.trackers.dictionaries import get_dictionary
from armtree.plugins.trackers.preprocess import Preprocessing

K = syn.nominal_camera()


def scene(ids, dictionary="4x4_50", effects=None, seed=0, size_mm=25.0, distance=300.0):
    rng = np.random.default_rng(seed)
    offsets = [(-60.0, -20.0), (0.0, 30.0), (60.0, -20.0)]
    placements = []
    for i, marker_id in enumerate(ids):
        rvec, tvec = syn.look_at_pose(
            distance, rng.uniform(-30, 30), rng.uniform(0, 360), offset_mm=offsets[i]
        )
        placements.append(syn.Placement(marker_id, size_mm, rvec, tvec))
    image, truth = syn.render_markers(
        "aruco", placements, K, effects=effects, dictionary=dictionary
    )
    return Frame(image, 0.0, K, np.zeros(5)), truth, {p.marker_id: p for p in placements}


@pytest.mark.parametrize(
    ("name", "size"), [("4x4_50", 4), ("DICT_6X6_250", 6), ("apriltag_36h11", 6), ("5X5_100", 5)]
)
def test_dictionaries_by_name(name, size):
    assert get_dictionary(name).markerSize == size


@pytest.mark.parametrize(
    ("name", "hint"), [("4x4_5O", "4x4_50"), ("apriltag_36h1", "apriltag_36h1")]
)
def test_unknown_dictionary_suggests_a_name(name, hint):
    with pytest.raises(ConfigError, match=f"did you mean '{hint}"):
        get_dictionary(name)


def test_three_markers_with_subpixel_corners_and_poses():
    frame, truth, placed = scene([0, 5, 7], effects=syn.Effects(noise=2.0, seed=2))
    dets = ArucoTracker(roles=TagRoles({}, 25.0)).detect(frame)
    assert sorted(d.id for d in dets) == [0, 5, 7]
    for det in dets:
        assert det.family == "aruco" and det.corners.shape == (4, 2)
        assert np.abs(det.corners - truth[det.id]).max() < 0.5
        assert np.linalg.norm(det.tvec - placed[det.id].tvec) < 3.0
        assert 0.0 <= det.quality < 0.5, "quality is the RMS reprojection error in px"


def test_other_dictionary_from_the_factory():
    frame, _, _ = scene([3, 200], dictionary="6x6_250")
    ctx = RigContext(
        profile={"tags": {"trash": {"ids": [200], "size_mm": 25}}}, clock=VirtualClock()
    )
    tracker = aruco_factory({"type": "aruco", "dictionary": "6x6_250"}, ctx)
    dets = {d.id: d for d in tracker.detect(frame)}
    assert set(dets) == {3, 200}
    assert dets[200].role == "trash" and dets[200].tvec is not None
    assert dets[3].role == "unknown" and dets[3].tvec is None


def test_seed_preprocessing_still_refines_on_grey():
    frame, truth, _ = scene([1, 2, 3], effects=syn.Effects(noise=1.0, seed=4))
    tracker = ArucoTracker(preprocessing=Preprocessing(threshold=0.4, blur=3))
    dets = tracker.detect(frame)
    assert sorted(d.id for d in dets) == [1, 2, 3]
    for det in dets:
        assert np.abs(det.corners - truth[det.id]).max() < 0.5


def test_detector_parameters_from_the_profile():
    params = detector_parameters(
        {"adaptiveThreshWinSizeMin": 5, "cornerRefinementMethod": "contour"}
    )
    assert params.adaptiveThreshWinSizeMin == 5
    import cv2

    assert params.cornerRefinementMethod == cv2.aruco.CORNER_REFINE_CONTOUR
    assert detector_parameters({}).cornerRefinementMethod == cv2.aruco.CORNER_REFINE_SUBPIX


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"adaptiveThreshWinSizeMn": 5}, "did you mean 'adaptiveThreshWinSizeMin'"),
        ({"adaptiveThreshWinSizeMin": "five"}, "expected int"),
        ({"detectInvertedMarker": 1}, "expected bool"),
        ({"cornerRefinementMethod": "sharp"}, "one of none, subpix"),
    ],
)
def test_bad_detector_parameters(overrides, message):
    with pytest.raises(ConfigError, match=message):
        detector_parameters(overrides)


def test_factory_rejects_bad_config():
    ctx = RigContext(profile=None, clock=VirtualClock())
    with pytest.raises(ConfigError, match="did you mean 'dictionary'"):
        aruco_factory({"dictonary": "4x4_50"}, ctx)
    with pytest.raises(ConfigError, match="unknown ArUco dictionary"):
        aruco_factory({"dictionary": "9x9_1"}, ctx)


def test_only_registered_and_empty_frames():
    frame, _, _ = scene([0, 5])
    from armtree.api.rig import TagSpec

    roles = TagRoles({5: TagSpec("ducky", (5,), 25.0)})
    assert [d.id for d in ArucoTracker(roles=roles, only_registered=True).detect(frame)] == [5]
    empty = Frame(np.full((480, 640), 128, np.uint8), 0.0, K, np.zeros(5))
    assert ArucoTracker().detect(empty) == []


def test_colour_frames_give_the_corners_of_their_grey_image():
    import cv2

    frame, truth, _ = scene([0, 5, 7], effects=syn.Effects(noise=2.0, blur=0.8, seed=3))
    bgr = Frame(cv2.cvtColor(frame.image, cv2.COLOR_GRAY2BGR), 0.0, K, np.zeros(5))
    tracker = ArucoTracker(roles=TagRoles({}, 25.0))
    from_grey = {d.id: d for d in tracker.detect(frame)}
    from_colour = {d.id: d for d in tracker.detect(bgr)}
    assert set(from_colour) == set(from_grey) == {0, 5, 7}
    for marker_id, det in from_colour.items():
        # the edges are sampled from the BGR frame as grey: the same to within rounding
        assert np.abs(det.corners - from_grey[marker_id].corners).max() < 0.02
        assert np.abs(det.corners - truth[marker_id]).max() < 0.5


def test_min_side_px_sets_the_detectors_perimeter_limit_per_frame_size():
    tracker = ArucoTracker()
    frame, _, _ = scene([4])
    assert [d.id for d in tracker.detect(frame)] == [4]
    assert tracker.parameters.minMarkerPerimeterRate == pytest.approx(4 * 10.0 / 640)
    small, _, _ = scene([4], distance=1000.0)  # a 20 px marker
    assert [d.id for d in ArucoTracker(min_side_px=30.0).detect(small)] == []
    assert [d.id for d in ArucoTracker(min_side_px=12.0).detect(small)] == [4]
    half = Frame(frame.image[::2, ::2].copy(), 0.0, K, np.zeros(5))
    tracker.detect(half)
    assert tracker.parameters.minMarkerPerimeterRate == pytest.approx(4 * 10.0 / 320)


def test_an_explicit_perimeter_rate_wins_and_a_bad_min_side_is_refused():
    ctx = RigContext(profile=None, clock=VirtualClock())
    tracker = aruco_factory({"detector": {"minMarkerPerimeterRate": 0.5}}, ctx)
    frame, _, _ = scene([4])
    # a 67 px marker's perimeter is below half of 640 px (an 80 px side)
    assert tracker.detect(frame) == []
    assert tracker.parameters.minMarkerPerimeterRate == pytest.approx(0.5)
    with pytest.raises(ConfigError, match="tracker.min_side_px"):
        aruco_factory({"min_side_px": 0}, ctx)
