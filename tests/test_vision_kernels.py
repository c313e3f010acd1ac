"""The trackers' whole-array kernels: grey levels, the square-to-quad map, quad tidying, overlaps."""

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.plugins.trackers import kernels

RAMP = np.tile(np.arange(200, dtype=np.uint8), (120, 1))  # grey level = x


def bilinear(image, x, y):
    """An independent reference: numpy bilinear interpolation, edges repeated."""
    h, w = image.shape
    x, y = np.clip(x, 0, w - 1), np.clip(y, 0, h - 1)
    x0, y0 = int(np.floor(x)), int(np.floor(y))
    x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
    fx, fy = x - x0, y - y0
    img = image.astype(float)
    top = img[y0, x0] * (1 - fx) + img[y0, x1] * fx
    return top * (1 - fy) + (img[y1, x0] * (1 - fx) + img[y1, x1] * fx) * fy


@settings(max_examples=200, deadline=None)
@given(st.floats(-50, 250), st.floats(-50, 170), st.integers(0, 2**32 - 1))
def test_grey_at_is_bilinear_with_edges_repeated(x, y, seed):
    image = np.random.default_rng(seed).integers(0, 256, (120, 200), dtype=np.uint8)
    assert abs(kernels.grey_at(image, (x, y)) - bilinear(image, x, y)) < 1e-9


def test_grey_at_reads_bgr_as_cvtcolor_and_never_outside_the_image():
    rng = np.random.default_rng(3)
    bgr = rng.integers(0, 256, (40, 50, 3), dtype=np.uint8)
    grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    for y in range(40):
        for x in range(50):
            # cvtColor rounds to a whole grey level
            assert abs(kernels.grey_at(bgr, (float(x), float(y))) - grey[y, x]) <= 0.5 + 1e-6
    corner = float(grey[0, 0])
    for x, y in ((np.nan, np.nan), (-np.inf, -1e300), (np.nan, 0.0)):
        assert abs(kernels.grey_at(bgr, (x, y)) - corner) <= 0.5 + 1e-6
    far = float(grey[-1, -1])
    assert abs(kernels.grey_at(bgr, (np.inf, 1e300)) - far) <= 0.5 + 1e-6


quads_strategy = st.tuples(
    st.floats(40, 160),
    st.floats(30, 90),
    st.floats(15, 35),
    st.floats(0, 360),
    st.floats(-0.4, 0.4),
)


def make_quad(cx, cy, half, spin_deg, skew):
    angles = np.radians(spin_deg) + np.array([0, 0.5, 1.0, 1.5]) * np.pi
    radii = half * np.array([1.0, 1.0 + skew, 1.0, 1.0 - skew])
    return np.stack([cx + radii * np.cos(angles), cy + radii * np.sin(angles)], axis=1)


@settings(max_examples=100, deadline=None)
@given(quads_strategy)
def test_sample_cells_maps_the_unit_square_onto_the_quad_as_opencv_does(params):
    quad = make_quad(*params)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5], [0.2, 0.7], [0.9, 0.1]])
    levels = kernels.sample_cells(
        RAMP, quad[None].astype(np.float64), uv[:4, None, :].copy(), uv[4:].copy()
    )[0]
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    homography = cv2.getPerspectiveTransform(square, quad.astype(np.float32))
    expected = cv2.perspectiveTransform(uv[None].astype(np.float64), homography)[0]
    # the ramp's grey level is x (inside the image): the level read is where the point went
    assert np.allclose(levels, np.clip(expected[:, 0], 0, 199), atol=1e-3)


def test_a_cell_is_the_mean_of_its_points_and_a_degenerate_quad_reads_one_level():
    quad = np.array([[[20.0, 10.0], [120.0, 10.0], [120.0, 110.0], [20.0, 110.0]]])
    cell = np.array([[[0.0, 0.5], [1.0, 0.5]]])  # x 20 and 120: mean 70
    assert kernels.sample_cells(RAMP, quad, cell, np.zeros((0, 2)))[0, 0] == pytest.approx(
        70.0, abs=1e-6
    )
    flat = np.array([[[30.0, 5.0], [30.0, 5.0], [30.0, 5.0], [30.0, 5.0]]])
    assert np.allclose(kernels.sample_cells(RAMP, flat, cell, np.zeros((1, 2))), 30.0, atol=1e-6)


def test_clockwise_quads_turns_and_filters():
    clockwise = np.array([[0, 0], [20, 0], [20, 20], [0, 20]], np.float32)  # y down
    small = clockwise / 4
    out = kernels.clockwise_quads(np.stack([clockwise[::-1], clockwise, small]), 12.0)
    assert out.shape == (2, 4, 2)
    assert np.array_equal(out[0], clockwise) and np.array_equal(out[1], clockwise)


def test_of_overlapping_readings_the_cleaner_then_the_larger_is_kept():
    square = np.array([[0, 0], [40, 0], [40, 40], [0, 40]], float)
    big, inner, apart = square * 2 - 20, square, square + 200
    quads = np.stack([big, inner, apart])
    # the big one needed corrections: the inner one wins, the one far away stays
    kept = kernels.best_of_overlapping(quads, np.array([2, 0, 1]), np.array([False, False, True]))
    assert kept.tolist() == [1, 2]
    # equally clean: the larger wins
    kept = kernels.best_of_overlapping(quads, np.array([0, 0, 0]), np.zeros(3, bool))
    assert kept.tolist() == [0, 2]
    # equally corrected, one ambiguous: the other wins
    kept = kernels.best_of_overlapping(quads[:2], np.array([1, 1]), np.array([True, False]))
    assert kept.tolist() == [1]


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (6, 1), (2, 2)])
def test_grey_at_on_images_one_pixel_thin(shape):
    image = np.random.default_rng(sum(shape)).integers(0, 256, shape, dtype=np.uint8)
    xs = np.array([-3.0, 0.0, 0.25, shape[1] - 1.0, shape[1] + 4.0, np.nan])
    ys = np.array([0.5, -1.0, shape[0] - 1.0, 0.75, np.inf, 0.0])
    got = kernels.grey_at(image, np.stack([xs, ys], axis=-1))
    assert got.shape == xs.shape
    assert np.allclose(
        got,
        [bilinear(image, x, y) for x, y in zip(np.nan_to_num(xs, nan=0.0), ys, strict=True)],
        atol=1e-9,
    )


@settings(max_examples=100, deadline=None)
@given(quads_strategy)
def test_unit_square_homographies_take_the_square_onto_the_quad(params):
    quad = make_quad(*params)
    homography, degenerate = kernels.unit_square_homographies(quad[None])
    square = np.array([[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1.0]])
    mapped = square @ homography[0].T
    assert not degenerate[0]
    assert np.allclose(mapped[:, :2] / mapped[:, 2:], quad, atol=1e-9)


def test_a_quad_of_one_point_has_no_homography():
    flat = np.array([[[30.0, 5.0]] * 4])
    assert kernels.unit_square_homographies(flat)[1].tolist() == [True]
