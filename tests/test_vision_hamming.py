"""The Hampy marker format, pinned by golden code words, and the hamming tracker on synthetic frames."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.api.clock import VirtualClock
from armtree.api.rig import Frame, RigContext, TagSpec
from armtree.errors import ConfigError
from armtree.plugins.trackers import hamming_code as hc
from armtree.plugins.trackers import synthetic as syn
from armtree.plugins.trackers.common import TagRoles
from armtree.plugins.trackers.hamming import HammingTracker, hamming_factory

# Hamming(7,4) code words of nibbles 0..15 in hampy 1.4.2's bit order
# (p1 p2 d1 p3 d2 d3 d4), as hampy.hamming.encode writes them.
GOLDEN_CODEWORDS = [
    "0000000", "1101001", "0101010", "1000011", "1001100", "0100101", "1100110", "0001111",
    "1110000", "0011001", "1011010", "0110011", "0111100", "1010101", "0010110", "1111111",
]  # fmt: skip
# HammingMarker(id).hamming_code of hampy 1.4.2, one string per row from the top.
GOLDEN_GRIDS = {
    1: ["0000000"] * 6 + ["1101001"],
    0x0ABCDEF: ["0000000", "1011010", "0110011", "0111100", "1010101", "0010110", "1111111"],
    228337701: ["1010101", "0011001", "0111100", "0101010", "1110000", "0101010", "0100101"],
}

K = syn.nominal_camera()


def rows(bits):
    return ["".join(str(int(b)) for b in row) for row in bits]


def test_codewords_match_hampy():
    assert rows(hc.CODEWORDS) == GOLDEN_CODEWORDS


@pytest.mark.parametrize("marker_id", sorted(GOLDEN_GRIDS))
def test_grids_match_hampy(marker_id):
    assert rows(hc.encode_id(marker_id)) == GOLDEN_GRIDS[marker_id]
    grid = hc.marker_grid(marker_id)
    assert grid.shape == (9, 9)
    border = np.ones((9, 9), bool)
    border[1:-1, 1:-1] = False
    assert not grid[border].any(), "the border is black"
    assert rows(grid[1:-1, 1:-1]) == GOLDEN_GRIDS[marker_id], "a white cell is a 1 bit"


@settings(max_examples=200, deadline=None)
@given(st.integers(0, hc.MAX_ID - 1))
def test_encode_decode_round_trip(marker_id):
    ids, corrected = hc.decode_bits(hc.encode_id(marker_id))
    assert int(ids) == marker_id and int(corrected) == 0


@settings(max_examples=200, deadline=None)
@given(
    st.integers(0, hc.MAX_ID - 1),
    st.lists(st.integers(0, 6), min_size=7, max_size=7),
    st.integers(1, 7),
)
def test_one_bit_per_row_is_corrected(marker_id, columns, n_rows):
    bits = hc.encode_id(marker_id)
    for r in range(n_rows):
        bits[r, columns[r]] ^= 1
    ids, corrected = hc.decode_bits(bits)
    assert int(ids) == marker_id and int(corrected) == n_rows


def test_two_bits_in_a_row_decode_to_another_id():
    bits = hc.encode_id(0x0ABCDEF)
    bits[3, [0, 4]] ^= 1
    ids, corrected = hc.decode_bits(bits)
    assert int(ids) != 0x0ABCDEF and int(corrected) == 1


@pytest.mark.parametrize("bad", [-1, hc.MAX_ID, 2.0, True])
def test_ids_out_of_range_are_refused(bad):
    with pytest.raises(ValueError):
        hc.encode_id(bad)


def scene(ids, effects=None, seed=0, distance=300.0, size_mm=25.0, spin=None):
    rng = np.random.default_rng(seed)
    offsets = [(-60.0, -20.0), (0.0, 30.0), (60.0, -20.0)]
    placements = []
    for i, marker_id in enumerate(ids):
        rvec, tvec = syn.look_at_pose(
            distance,
            tilt_deg=rng.uniform(-30, 30),
            spin_deg=rng.uniform(0, 360) if spin is None else spin,
            offset_mm=offsets[i],
        )
        placements.append(syn.Placement(marker_id, size_mm, rvec, tvec))
    image, truth = syn.render_markers("hamming", placements, K, effects=effects)
    return Frame(image, 0.0, K, np.zeros(5)), truth, placements


def test_three_markers_found_with_corners_and_poses():
    frame, truth, placements = scene([1, 0x0ABCDEF, 228337701], syn.Effects(noise=2.0, seed=1))
    tracker = HammingTracker(roles=TagRoles({}, default_size_mm=25.0))
    dets = tracker.detect(frame)
    assert sorted(d.id for d in dets) == sorted(truth)
    for det in dets:
        assert det.family == "hamming" and not det.ambiguous and det.quality == 0
        assert np.abs(det.corners - truth[det.id]).max() < 0.5
        placement = next(p for p in placements if p.marker_id == det.id)
        assert np.linalg.norm(det.tvec - placement.tvec) < 3.0
        assert det.role == "unknown" and det.size_mm == 25.0


@pytest.mark.parametrize("spin", [0.0, 90.0, 180.0, 270.0])
def test_each_rotation_gives_one_id_and_printed_corner_order(spin):
    frame, truth, _ = scene([0x0ABCDEF], spin=spin)
    dets = HammingTracker().detect(frame)
    assert len(dets) == 1 and dets[0].id == 0x0ABCDEF
    # corners[0] is the top-left of the marker as printed, wherever it is in the image
    assert np.abs(dets[0].corners - truth[0x0ABCDEF]).max() < 0.5
    assert dets[0].tvec is None, "no size known, so no pose"


def test_marker_that_reads_as_two_ids_is_one_ambiguous_detection():
    # hampy.detect_markers returns ids 2 and 2 << 24 for this one marker
    frame, _, _ = scene([2])
    dets = HammingTracker().detect(frame)
    assert [(d.id, d.ambiguous) for d in dets] == [(2, True)]


def test_registered_id_settles_an_ambiguous_marker():
    roles = TagRoles({2 << 24: TagSpec("duckybot", (2 << 24,), 25.0)})
    frame, _, _ = scene([2])
    dets = HammingTracker(roles=roles).detect(frame)
    assert [(d.id, d.ambiguous, d.role) for d in dets] == [(2 << 24, False, "duckybot")]


def flip_cells(marker_id, cells):
    grid = hc.marker_grid(marker_id)
    for r, c in cells:
        grid[r + 1, c + 1] ^= 1
    return grid


def smudge_cells(marker_id, cells, right=()):
    """The marker's cells as grey levels (black 30, white 230, the quiet zone 200) with
    ``cells`` (row, column of the data grid) grey enough that, sharpened against their
    neighbours as the tracker reads them, they land just on the wrong side of its
    threshold (115, midway between the black border and the quiet zone): noise, not a
    clearly wrong cell; ``right`` cells just on the right side."""
    grid = hc.marker_grid(marker_id) * 200.0 + 30.0
    padded = np.pad(grid, 1, constant_values=200.0)
    for (r, c), wrong in [*((cell, True) for cell in cells), *((cell, False) for cell in right)]:
        y, x = r + 2, c + 2
        around = 0.25 * (padded[y - 1, x] + padded[y + 1, x] + padded[y, x - 1] + padded[y, x + 1])
        white = grid[r + 1, c + 1] > 115.0
        target = 105.0 if white == wrong else 125.0
        grid[r + 1, c + 1] = (target + 1.5 * around) / 2.5  # sharpened: 2.5 g - 1.5 around
    return grid


def render_grid(grid, side=180):
    import cv2

    img = np.full((480, 640), 200, np.uint8)
    grid = np.asarray(grid, float)
    levels = np.round(grid if grid.max() > 1 else grid * 200 + 30).astype(np.uint8)
    square = cv2.resize(levels, (side, side), interpolation=cv2.INTER_NEAREST)
    img[100 : 100 + side, 200 : 200 + side] = square
    return Frame(img, 0.0, K, np.zeros(5))


def test_single_bit_errors_are_corrected_and_counted():
    marker_id = 228337701
    frame = render_grid(smudge_cells(marker_id, [(0, 3), (5, 6)]))
    dets = HammingTracker().detect(frame)
    assert [(d.id, d.quality) for d in dets] == [(marker_id, 2.0)]


def test_too_many_errors_are_rejected():
    frame = render_grid(smudge_cells(228337701, [(0, 3), (2, 2), (5, 6)]))
    tracker = HammingTracker()
    assert tracker.detect(frame) == [] and tracker.unread == 1
    assert len(HammingTracker(max_corrected_bits=3).detect(frame)) == 1


def test_a_clearly_wrong_cell_is_not_corrected():
    # a cell printed (or covered) the other colour reads as sure as the right ones: the
    # format's code cannot tell damage from another marker, so no correction flips it
    tracker = HammingTracker(max_corrected_bits=9)
    assert tracker.detect(render_grid(flip_cells(228337701, [(0, 3)]))) == []
    assert tracker.unread == 1


def test_a_row_nearly_as_close_to_two_code_words_is_not_read():
    # three cells of a row in doubt, where its code word and another one differ: two read
    # as the other's, one as its own. The other code word is one doubtful flip away, the
    # right one two: either would be a guess.
    marker_id, row = 228337701, 1
    own = hc.encode_id(marker_id)[row]
    other = next(w for w in hc.CODEWORDS if int((w != own).sum()) == 3)
    cells = [(row, int(c)) for c in np.flatnonzero(other != own)]
    frame = render_grid(smudge_cells(marker_id, cells[:2], right=cells[2:]))
    assert HammingTracker(max_corrected_bits=9).detect(frame) == []
    dets = HammingTracker(max_corrected_bits=9, min_row_gap=0.0).detect(frame)
    assert [(d.id, d.quality) for d in dets] != [], "read, as a guess, without the gap"


def test_plain_squares_and_noise_give_nothing():
    rng = np.random.default_rng(3)
    img = rng.integers(0, 256, (480, 640), dtype=np.uint8)
    img[50:150, 50:150] = 20  # a black square: all-black inside, rejected as hampy does
    img[200:300, 300:400] = 20
    img[220:280, 320:380] = 230  # a black frame around a white square
    assert HammingTracker().detect(Frame(img, 0.0, K, np.zeros(5))) == []


def test_only_registered_drops_other_ids():
    frame, _, _ = scene([1, 0x0ABCDEF])
    roles = TagRoles({1: TagSpec("ducky", (1,), 25.0)})
    dets = HammingTracker(roles=roles, only_registered=True).detect(frame)
    assert [(d.id, d.role, d.size_mm) for d in dets] == [(1, "ducky", 25.0)]
    assert dets[0].tvec is not None


def context(profile):
    return RigContext(profile=profile, clock=VirtualClock())


def test_factory_reads_tags_and_preprocessing():
    profile = {"tags": {"ducky": {"id": 1, "size_mm": 25}, "trash": {"ids": [5, 6], "size_mm": 30}}}
    tracker = hamming_factory(
        {"type": "hamming", "preprocess": {"adaptive": True, "blur": 3}}, context(profile)
    )
    assert tracker.preprocessing.adaptive and tracker.preprocessing.blur == 3
    assert tracker.roles.describe(6) == ("trash", 30.0)
    assert hamming_factory({}, context(None)).preprocessing.threshold == 0.4  # Showers 2016


@pytest.mark.parametrize(
    ("config", "profile", "message"),
    [
        ({"max_corected_bits": 1}, None, "did you mean 'max_corrected_bits'"),
        ({"preprocess": {"threshold": 40}}, None, "between 0 and 1"),
        ({"preprocess": {"blur": 4}}, None, "odd"),
        ({"size_mm": 0}, None, "> 0"),
        ({}, {"tags": {"ducky": {"id": 1, "size_mm": 0}}}, "positive"),
        ({}, {"tags": {"ducky": {"id": 1}}}, "size_mm"),
        ({"min_side_px": "big"}, None, "min_side_px"),
    ],
)
def test_factory_config_errors(config, profile, message):
    with pytest.raises(ConfigError, match=message):
        hamming_factory(config, context(profile))


def test_wrong_image_type_is_a_value_error():
    frame = Frame(np.zeros((48, 64), np.float32), 0.0, K, np.zeros(5))
    with pytest.raises(ValueError, match="8-bit"):
        HammingTracker().detect(frame)


def test_registered_id_wins_over_an_upside_down_reading():
    # id 1 (not a valid id: hamming_code.id_problem) turned 180 degrees is one bit away
    # from 3 << 24; with this cell in doubt the upside-down reading is exact while the
    # right one needs a correction.
    marker_id, alias = 1, 3 << 24
    for r in range(7):
        for c in range(7):
            grid = flip_cells(marker_id, [(r, c)])
            inner = grid[1:-1, 1:-1]
            ids, corr = hc.decode_bits(np.stack([inner, np.rot90(inner, 2)]))
            if ids.tolist() == [marker_id, alias] and corr.tolist() == [1, 0]:
                break
        else:
            continue
        break
    frame = render_grid(smudge_cells(marker_id, [(r, c)]))
    assert [d.id for d in HammingTracker().detect(frame)] == [alias], "as hampy would read it"
    roles = TagRoles({marker_id: TagSpec("ducky", (marker_id,), 25.0)})
    dets = HammingTracker(roles=roles).detect(frame)
    assert [(d.id, d.quality, d.ambiguous) for d in dets] == [(marker_id, 1.0, False)]


def test_profile_errors_point_at_the_value(tmp_path):
    from armtree.loader.profile import load_profile

    path = tmp_path / "rig.yaml"
    path.write_text(
        "profile: rig\n"
        "arm: {type: dobot_v1, port: sim}\n"
        "tracker: {type: hamming, preprocess: {blur: 4}}\n"
        "tags:\n"
        "  ducky: {id: 69937, size_mm: 25}\n"
    )
    # The tracker's own checks run while the profile loads (armtree check), at the value.
    with pytest.raises(ConfigError) as err:
        load_profile(str(path))
    assert err.value.file == str(path) and err.value.line == 3
    assert "tracker.preprocess.blur" in err.value.message
    path.write_text(path.read_text().replace("blur: 4", "blur: 3"))
    profile = load_profile(str(path))
    good = hamming_factory({"type": "hamming"}, context(profile))
    assert good.roles.describe(69937) == ("ducky", 25.0)


def test_dark_blobs_and_all_black_insides_are_not_markers():
    import cv2

    rng = np.random.default_rng(5)
    img = np.clip(rng.normal(150, 5, (480, 640)), 0, 255).astype(np.uint8)
    cv2.ellipse(img, (150, 250), (25, 60), 30, 0, 360, 50, -1)
    grid = hc.marker_grid(1)
    grid[1:-1, 1:-1] = 0  # an all-black inside would decode as id 0
    grid[4, 4] = 1  # one stray white cell: still id 0 after correction
    square = cv2.resize(grid * np.uint8(200) + 30, (90, 90), interpolation=cv2.INTER_NEAREST)
    img[300:390, 400:490] = square
    img[290:300, 390:500] = img[390:400, 390:500] = 230
    img[290:400, 390:400] = img[290:400, 490:500] = 230
    assert HammingTracker().detect(Frame(img, 0.0, K, np.zeros(5))) == []


def test_a_frame_full_of_dark_squares_is_read_without_error():
    # 130 candidate squares (a chessboard, a printed sheet) need more sample points than
    # OpenCV's remap takes in one row or column; none of them is a marker.
    image = np.full((480, 640), 230, np.uint8)
    for i in range(13):
        for j in range(10):
            image[10 + j * 46 : 40 + j * 46, 10 + i * 48 : 40 + i * 48] = 20
    tracker = HammingTracker()
    assert len(tracker.candidates(image)) == 130
    assert tracker.detect(Frame(image, 0.0, None, None)) == []
    # a marker among them is still read
    marker, _ = syn.render_markers(
        "hamming",
        [syn.Placement(1234, 25.0, *syn.look_at_pose(300.0, 0.0, 0.0, (0.0, 0.0)))],
        syn.nominal_camera(),
        background=230.0,
    )
    image[200:280, 280:360] = marker[200:280, 280:360]
    assert [d.id for d in tracker.detect(Frame(image, 0.0, None, None))] == [1234]


def test_a_marker_on_a_dark_sheet_is_found_and_a_dark_rings_hole_is_not_a_candidate():
    import cv2

    marker, _ = syn.render_markers(
        "hamming",
        [syn.Placement(4321, 25.0, *syn.look_at_pose(300.0, 0.0, 0.0, (0.0, 0.0)))],
        syn.nominal_camera(),
        background=230.0,
    )
    image = np.full((480, 640), 230, np.uint8)
    # a dark sheet with a white window, the marker inside the window: the marker's
    # outline is nested inside the sheet's hole
    image[150:330, 220:420] = 30
    image[185:295, 265:375] = marker[185:295, 265:375]
    # a dark ring: its square hole must not be taken for a dark square
    cv2.rectangle(image, (40, 40), (140, 140), 30, 12)
    tracker = HammingTracker()
    quads = tracker.candidates(image)
    at_ring = quads[np.hypot(*(quads.mean(axis=1) - [90, 90]).T) < 5]
    sides = np.hypot(*(at_ring - np.roll(at_ring, 1, axis=1)).transpose(2, 0, 1))
    # the ring's outline (112 px) is a dark square; its hole (88 px) is not
    assert len(at_ring) == 1 and sides.min() > 100
    assert [d.id for d in tracker.detect(Frame(image, 0.0, None, None))] == [4321]
