"""Small, blurred Hampy markers: read by fitting blurred code words (``hamming_blur``).

At 16 px a side a Hampy marker has 1.8 px a cell; a pixel of blur merges them, and
neither the frame's threshold nor the cells' own reading finds the id. The fine
search and the blur fit must, without reading clutter or a wrong id.
"""

import cv2
import numpy as np
import pytest

from armtree.api.rig import Frame
from armtree.plugins.trackers import synthetic as syn
from armtree.plugins.trackers.hamming import HammingTracker
from armtree.plugins.trackers.hamming_blur import (
    INSET_PX,
    _own_terms,
    _PixelFit,
    _row_search,
    hamming_blur_reader,
)
from armtree.plugins.trackers.hamming_code import CODEWORDS
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
    ids, turns, _ = hamming_blur_reader().read(image, quads)
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
    border: the fit reads the marker from a quad grown by 0.3 px a side (the first
    reading reads inside it, the pixel fit moves its corners onto the border)."""
    image = frame_with([IDS[1]], 16, 0.8, 1.0, seed=4)
    tracker = HammingTracker()
    quads = tracker.candidates(image)
    truth = [d for d in tracker.detect(Frame(image, 0.0, K, np.zeros(5))) if d.id == IDS[1]]
    assert truth, "the marker itself must read for this test to say anything"
    corners = np.asarray(truth[0].corners, np.float64).reshape(4, 2)
    centre = corners.mean(axis=0)
    side = float(np.linalg.norm(corners - np.roll(corners, 1, axis=0), axis=1).mean())
    grown = centre + (corners - centre) * (1 + 0.6 / side)
    ids, _, fitted = hamming_blur_reader().read(image, np.stack([grown, corners]))
    assert ids.tolist() == [IDS[1]] * 2
    assert np.abs(fitted[0] - fitted[1]).max() < 0.05, "the fit did not move the corners back"
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


def blurred_marker(marker_id: int, side_mm: float, blur_px: float, noise: float, seed: int):
    """A frame of one marker, tilted, drawn exactly (:mod:`.synthetic`), and its corners."""
    rvec, tvec = syn.look_at_pose(810.0 * side_mm / 16.0, 25.0, 30.0 + 40.0 * seed)
    effects = syn.Effects(noise=noise, blur=blur_px, seed=seed)
    image, truth = syn.render_markers(
        "hamming", [syn.Placement(marker_id, side_mm, rvec, tvec)], K, effects=effects
    )
    return image, truth[marker_id]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_pixel_fit_puts_the_corners_on_the_border_and_fits_to_the_noise(seed):
    """From corners 0.4 px off, the fit on the pixels finds them to a tenth of a pixel
    and explains all but what noise of 3 grey levels leaves (against 190 of contrast)."""
    image, corners = blurred_marker(IDS[0], 25.0, 0.8, 3.0, seed)
    off = corners + np.random.default_rng(seed).uniform(-0.4, 0.4, corners.shape)
    reader = hamming_blur_reader()
    nibbles, turn, _ = reader.fit(reader.levels(image, off[None], INSET_PX))
    printed = off[None, (turn[0] + np.arange(4)) % 4]
    fit = _PixelFit(image, printed)
    read, top, second, uneven = fit.read(nibbles)
    assert int((read[0] << 4 * np.arange(6, -1, -1)).sum()) == IDS[0]
    assert top[0] > 0.99, top
    assert uneven[0] < 2.5, "the misfit is not noise"
    assert (1 - second[0] ** 2) / (1 - top[0] ** 2) > 3.0, "another reading fits nearly as well"
    true_printed = corners[(turn[0] + np.arange(4)) % 4]
    assert np.abs(fit.corners()[0] - true_printed).max() < 0.12


def test_the_row_search_finds_the_words_of_a_clean_prediction():
    rng = np.random.default_rng(3)
    cells = rng.normal(size=(300, 50))  # any 50 predictions, the last the print's rest
    truth = rng.integers(0, 16, 7)
    x = np.append(CODEWORDS[truth].ravel(), 1.0)
    levels = cells @ x
    levels /= np.linalg.norm(levels)
    gram = cells.T @ cells
    words, top, second = _row_search(cells.T @ levels, gram, _own_terms(gram), None, 4)
    assert words.tolist() == truth.tolist()
    assert top == pytest.approx(1.0) and second < 0.99


def test_the_fine_search_keeps_a_thin_dark_ring_and_drops_lone_dark_pixels():
    from armtree.plugins.trackers.hamming import FINE_MOST_LIGHT
    from armtree.plugins.trackers.preprocess import dark_after_blur3, mostly_dark

    light = np.full((40, 40), 255, np.uint8)
    light[10, 5:35] = 0  # a line one pixel thick
    light[25, 20] = 0  # a pixel of noise
    light[30, 10:12] = 0  # two
    dark = mostly_dark(light, FINE_MOST_LIGHT)
    assert dark[10, 8:32].all() and not dark[25, 20] and not dark[30, 10:12].any()
    assert not dark_after_blur3(light)[10].any(), "Showers 2016's blur drops the line"


def test_a_batch_with_a_point_and_a_quad_off_the_frame_reads_only_the_marker():
    """Degenerate candidates and ones hanging off the frame are refused, not failed on."""
    image, corners = blurred_marker(IDS[2], 25.0, 0.7, 2.0, seed=5)
    point = np.full((4, 2), 100.0)
    off = np.array([[-8.0, -8.0], [9.0, -8.0], [9.0, 9.0], [-8.0, 9.0]])
    quads = np.stack([point, off, corners, off + [630.0, 470.0]])
    ids, turns, fitted = hamming_blur_reader().read(image, quads)
    assert ids.tolist() == [-1, -1, IDS[2], -1]
    assert turns[2] >= 0 and np.isfinite(fitted).all()
