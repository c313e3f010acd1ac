"""Marker families: which ids are valid (the Hampy rule), and every id a shipped profile uses,
in every family, drawn by the generator and read back by that family's tracker."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import armtree
from armtree.api.rig import Frame
from armtree.config.resolve import shipped_dir
from armtree.errors import ConfigError
from armtree.plugins.trackers import hamming_code as hc
from armtree.plugins.trackers import synthetic as syn
from armtree.plugins.trackers.aruco import ArucoTracker
from armtree.plugins.trackers.families import (
    apriltag_dictionary,
    family_named,
    tracker_family,
)
from armtree.plugins.trackers.hamming import HammingTracker

K = syn.nominal_camera()
#: The families the shipped trees run with: the profiles' own, AprilTag, Hampy.
FAMILIES = ("4x4_50", "apriltag_36h11", "hamming")


@pytest.mark.parametrize(
    ("marker_id", "why"),
    [
        (0, "all black"),
        (hc.MAX_ID - 1, "all white"),
        (1, "turned 180 degrees it reads as id 50331648 after 1 correction"),
        (2, "turned 180 degrees it reads as id 33554432 as it is"),
        (7, "turned 180 degrees"),
    ],
)
def test_small_ids_and_plain_insides_are_not_valid_hamming_ids(marker_id, why):
    problem = hc.id_problem(marker_id)
    assert problem is not None and why in problem
    assert not hc.is_valid_id(marker_id)


def test_the_rule_follows_the_corrections_the_tracker_allows():
    # 275's nearest turns are 3 flips from other ids: valid while the tracker corrects 2
    assert min(d for d, _ in hc.turn_readings(275)) == 3
    assert hc.is_valid_id(275, 2) and not hc.is_valid_id(275, 3)
    assert hc.valid_ids_near(0) == [275, 277, 279]


@settings(max_examples=150, deadline=None)
@given(st.integers(1, hc.MAX_ID - 2))
def test_each_turn_is_as_many_flips_from_the_id_it_names(marker_id):
    grid = hc.encode_id(marker_id)
    for k, (flips, other) in enumerate(hc.turn_readings(marker_id), start=1):
        turned = np.rot90(grid, k)
        assert other not in hc.REFUSED_IDS
        assert int((hc.encode_id(other) != turned).sum()) == flips
        # and no accepted id is nearer: each row at its nearest code word, the words an id
        _, corrected = hc.decode_bits(turned)
        assert flips >= int(corrected)
    valid = hc.is_valid_id(marker_id)
    assert valid == (min(d for d, _ in hc.turn_readings(marker_id)) > 2)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, hc.MAX_ID - 2))
def test_a_valid_id_turned_never_decodes_as_an_id_within_the_corrections(marker_id):
    if not hc.is_valid_id(marker_id):
        return
    grid = hc.encode_id(marker_id)
    for k in (1, 2, 3):
        ids, corrected = hc.decode_bits(np.rot90(grid, k))
        assert int(corrected) > 2 or int(ids) in hc.REFUSED_IDS


def test_family_names_sizes_and_mistakes():
    assert family_named("hamming").count == hc.MAX_ID
    assert family_named("DICT_APRILTAG_36h11").name == "apriltag_36h11"
    assert family_named("apriltag_36h11").count == 587
    assert family_named("4x4_50").id_error(50).startswith("4x4_50 has ids 0 to 49, not 50")
    with pytest.raises(ConfigError, match="did you mean 'hamming'"):
        family_named("haming")
    assert apriltag_dictionary("36h11") == apriltag_dictionary("tag36h11") == "apriltag_36h11"
    with pytest.raises(ConfigError, match="16h5, 25h9, 36h10, 36h11"):
        apriltag_dictionary("41h12")
    assert tracker_family({"type": "apriltag"}).name == "apriltag_36h11"
    assert tracker_family({"type": "aruco"}).name == "4x4_50"
    assert tracker_family({"type": "someone_elses"}) is None


def _shipped_ids():
    """(profile, role, family, id) for every tag id of every shipped profile."""
    out = []
    for path in sorted(shipped_dir("profile").glob("*.yaml")):
        profile = armtree.load_profile(str(path))
        for role, spec in profile.tags().items():
            for family in FAMILIES:
                for marker_id in spec.in_family(family).ids:
                    out.append((path.stem, role, family, marker_id))
    return out


def _tracker(family):
    if family == "hamming":
        return HammingTracker()
    return ArucoTracker(family)


def test_every_id_a_shipped_profile_uses_is_valid_drawn_and_read_in_every_family():
    cases = _shipped_ids()
    assert {c[2] for c in cases} == set(FAMILIES) and len(cases) > 40
    ids = {(family, marker_id) for _, _, family, marker_id in cases}
    for family, marker_id in sorted(ids):
        assert family_named(family).id_error(marker_id) is None, (family, marker_id)
        generator = "hamming" if family == "hamming" else "aruco"
        rvec, tvec = syn.look_at_pose(300.0, 20.0, 35.0)
        image, truth = syn.render_markers(
            generator,
            [syn.Placement(marker_id, 25.0, rvec, tvec)],
            K,
            dictionary=family,
            effects=syn.Effects(noise=2.0, blur=0.6, seed=marker_id % 1000),
        )
        dets = _tracker(family).detect(Frame(image, 0.0, K, np.zeros(5)))
        assert [d.id for d in dets] == [marker_id], (family, marker_id)
        assert not dets[0].ambiguous
        assert np.abs(dets[0].corners - truth[marker_id]).max() < 1.0
