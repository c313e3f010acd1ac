"""Small, blurred Hampy markers: read by fitting blurred code words (``hamming_blur``).

At 16 px a side a Hampy marker has 1.8 px a cell; a pixel of blur merges them, and
neither the frame's threshold nor the cells' own reading finds the id. The fine
search and the blur fit must, without reading clutter or a wrong id.
"""

import cv2
import numpy as np
import pytest

from armtree.api.rig import Frame
from armtree.plugins.trackers.hamming import HammingTracker
from armtree.plugins.trackers.hamming_blur import hamming_blur_reader
from armtree.plugins.trackers.markers import marker_image

K = np.array([[810.0, 0, 320], [0, 810.0, 240], [0, 0, 1]])
IDS = (69937, 69975, 1234567)


def frame_with(ids, side_px: int, blur_px: float, noise: float, seed: int) -> np.ndarray:
    """A grey 640x480 frame with each marker drawn ``side_px`` a side (its quiet zone
    around it), blurred and noisy like a small webcam view."""
    rng = np.random.default_rng(seed)
    big = np.full((480 * 4, 640 * 4), 150, np.float32)
    for k, marker_id in enumerate(ids):
        printed = marker_image("hamming", marker_id, side_px * 4 * 11 // 9, quiet_cells=1.0)
        printed = cv2.cvtColor(printed, cv2.COLOR_BGR2GRAY) if printed.ndim == 3 else printed
        angle = float(rng.uniform(0, 360))
        pad = printed.shape[0] // 3  # room for the corners when turned: a white card
        printed = cv2.copyMakeBorder(printed, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255)
        h, w = printed.shape
        turn = cv2.getRotationMatrix2D((w / 2, h / 2), angle, 1.0)
        turned = cv2.warpAffine(printed.astype(np.float32), turn, (w, h), borderValue=215.0)
        x, y = 400 + 600 * k, 700 + 150 * (k % 2)
        big[y : y + h, x : x + w] = 0.2 * 150 + 0.8 * turned
    small = cv2.resize(big, (640, 480), interpolation=cv2.INTER_AREA)
    small = cv2.GaussianBlur(small, (0, 0), blur_px)
    small += rng.normal(0, noise, small.shape)
    return np.clip(small, 0, 255).astype(np.uint8)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_markers_of_16_px_with_blur_are_read_only_by_the_fit(seed):
    image = frame_with(IDS, 16, 0.8, 3.0, seed)
    frame = Frame(image, 0.0, K, np.zeros(5))
    found = sorted(d.id for d in HammingTracker().detect(frame))
    cells_only = HammingTracker(fine_search=False, blur_fit=False).detect(frame)
    assert set(found) <= set(IDS), f"a wrong id: {found}"
    assert len(found) >= 2, f"16 px markers with blur: read {found} of {IDS}"
    assert len(cells_only) < len(found), "the cells alone read as many: the test shows nothing"


def test_the_fit_reads_nothing_in_clutter():
    rng = np.random.default_rng(5)
    image = cv2.GaussianBlur(rng.integers(0, 255, (480, 640)).astype(np.uint8), (0, 0), 2.0)
    quads = np.array(
        [
            [[x, y], [x + 16, y], [x + 16, y + 16], [x, y + 16]]
            for x in range(20, 600, 40)
            for y in range(20, 440, 40)
        ],
        np.float32,
    )
    ids, turns = hamming_blur_reader().read(image, quads)
    assert (ids == -1).all() and (turns == -1).all()


def test_the_fit_reads_a_clean_marker_and_its_turn():
    image = frame_with([IDS[0]], 20, 0.6, 1.0, seed=7)
    det = HammingTracker(fine_search=True).detect(Frame(image, 0.0, K, np.zeros(5)))
    assert [d.id for d in det] == [IDS[0]]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_markers_of_14_px_with_blur_are_read_without_a_wrong_id(seed):
    image = frame_with(IDS, 14, 0.7, 2.0, seed)
    found = [d.id for d in HammingTracker().detect(Frame(image, 0.0, K, np.zeros(5)))]
    assert set(found) <= set(IDS), f"a wrong id: {found}"
    assert len(found) >= 2, f"14 px markers with blur: read {found} of {IDS}"


def test_a_candidate_drawn_a_little_large_is_read_from_inside_it():
    """The candidate search's corners sit a few tenths of a pixel outside a blurred
    border: the fit reads the marker from a quad grown by 0.3 px a side."""
    image = frame_with([IDS[1]], 16, 0.8, 1.0, seed=4)
    tracker = HammingTracker()
    quads = tracker.candidates(image)
    truth = [d for d in tracker.detect(Frame(image, 0.0, K, np.zeros(5))) if d.id == IDS[1]]
    assert truth, "the marker itself must read for this test to say anything"
    corners = np.asarray(truth[0].corners, np.float64).reshape(4, 2)
    centre = corners.mean(axis=0)
    side = float(np.linalg.norm(corners - np.roll(corners, 1, axis=0), axis=1).mean())
    grown = centre + (corners - centre) * (1 + 0.6 / side)
    ids, _ = hamming_blur_reader().read(image, grown[None])
    assert ids.tolist() == [IDS[1]]
    assert len(quads) >= 1


def ragged_square(side: int, bumps: int, seed: int) -> np.ndarray:
    """255 inside a square of ``side`` px whose edges carry two-pixel bumps, as noise
    leaves a small marker's thresholded border, on a 0 background."""
    rng = np.random.default_rng(seed)
    dark = np.zeros((80, 80), np.uint8)
    lo, hi = 30, 30 + side
    dark[lo:hi, lo:hi] = 255
    for _ in range(bumps):
        at = int(rng.integers(lo + 3, hi - 5))
        edge = int(rng.integers(4))
        if edge == 0:
            dark[lo - 2 : lo, at : at + 2] = 255
        elif edge == 1:
            dark[hi : hi + 2, at : at + 2] = 255
        elif edge == 2:
            dark[at : at + 2, lo - 2 : lo] = 255
        else:
            dark[at : at + 2, hi : hi + 2] = 255
    return dark


def test_a_ragged_small_square_is_a_candidate_from_its_hull_and_a_disc_is_not():
    from armtree.plugins.trackers.preprocess import dark_quads

    ragged = [ragged_square(14, 3, seed) for seed in range(12)]
    plain = sum(len(dark_quads(d, 10.0)) for d in ragged)
    hulled = [dark_quads(d, 10.0, hull_fallback=True) for d in ragged]
    assert all(len(q) == 1 for q in hulled), [len(q) for q in hulled]
    assert plain == 0, "a ragged square was a quad already: the test shows less"
    for quad in hulled:
        sides = np.linalg.norm(quad[0] - np.roll(quad[0], 1, axis=0), axis=1)
        assert np.all(np.abs(sides - 14) < 2.5), sides
    disc = np.zeros((80, 80), np.uint8)
    cv2.circle(disc, (40, 40), 9, 255, -1)
    assert len(dark_quads(disc, 10.0, hull_fallback=True)) == 0
