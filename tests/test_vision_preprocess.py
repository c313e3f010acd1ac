"""Preprocessing shortcuts give OpenCV's own pixels."""

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.plugins.trackers.preprocess import (
    Preprocessing,
    dark_after_blur3,
    mostly_dark,
    threshold_image,
    to_gray,
)


@settings(max_examples=60, deadline=None)
@given(
    st.integers(3, 40),
    st.integers(3, 40),
    st.floats(0.0, 1.0),
    st.integers(0, 2**32 - 1),
)
def test_dark_after_blur3_is_blur_then_threshold(height, width, white, seed):
    rng = np.random.default_rng(seed)
    binary = (rng.random((height, width)) < white).astype(np.uint8) * 255
    expected = cv2.threshold(cv2.GaussianBlur(binary, (3, 3), 0), 127, 255, cv2.THRESH_BINARY_INV)
    assert np.array_equal(dark_after_blur3(binary), expected[1])


@settings(max_examples=60, deadline=None)
@given(st.integers(3, 40), st.integers(3, 40), st.floats(0.0, 255.0), st.integers(0, 2**32 - 1))
def test_dark_after_blur3_binarises_grey_at_any_level(height, width, level, seed):
    rng = np.random.default_rng(seed)
    gray = rng.integers(0, 256, (height, width), dtype=np.uint8)
    binary = cv2.threshold(gray, level, 255, cv2.THRESH_BINARY)[1]
    expected = cv2.threshold(cv2.GaussianBlur(binary, (3, 3), 0), 127, 255, cv2.THRESH_BINARY_INV)
    assert np.array_equal(dark_after_blur3(gray, level), expected[1])


@pytest.mark.parametrize(
    "prep",
    [
        Preprocessing(threshold=0.4, blur=3),
        Preprocessing(adaptive=True, blur=3),
        Preprocessing(threshold=0.5, blur=5),
        Preprocessing(threshold=0.4),
    ],
)
def test_dark_mask_matches_thresholding_the_preprocessed_image(prep):
    rng = np.random.default_rng(4)
    gray = cv2.GaussianBlur((rng.random((120, 160)) * 255).astype(np.uint8), (7, 7), 2)
    expected = cv2.threshold(prep.apply(gray), 127, 255, cv2.THRESH_BINARY_INV)[1]
    assert np.array_equal(prep.dark(gray), expected)


def test_dark_mask_needs_a_binarising_preprocessing():
    with pytest.raises(ValueError, match="binarising"):
        Preprocessing(blur=3).dark(np.zeros((10, 10), np.uint8))


def test_row_wise_grey_and_threshold_equal_opencv():
    rng = np.random.default_rng(5)
    bgr = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
    assert np.array_equal(to_gray(bgr), cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY))
    bgra = rng.integers(0, 256, (48, 64, 4), dtype=np.uint8)
    assert np.array_equal(to_gray(bgra), cv2.cvtColor(bgra, cv2.COLOR_BGRA2GRAY))
    crop = bgr[5:40, 7:50]  # not contiguous
    assert np.array_equal(to_gray(crop), cv2.cvtColor(crop, cv2.COLOR_BGR2GRAY))
    gray = to_gray(bgr)
    otsu = cv2.THRESH_BINARY_INV | cv2.THRESH_OTSU
    assert np.array_equal(threshold_image(gray, 0, otsu), cv2.threshold(gray, 0, 255, otsu)[1])


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 40), st.integers(2, 40), st.integers(0, 16), st.integers(0, 2**32 - 1))
def test_mostly_dark_counts_light_neighbours_as_the_gaussian_weighs_them(
    height, width, most_light, seed
):
    rng = np.random.default_rng(seed)
    binary = (rng.random((height, width)) < 0.5).astype(np.uint8) * 255
    kernel = np.outer([1, 2, 1], [1, 2, 1]).astype(np.float32)
    light = cv2.filter2D(
        (binary > 0).astype(np.float32), -1, kernel, borderType=cv2.BORDER_REFLECT_101
    )
    expected = np.where(np.rint(light) <= most_light, 255, 0).astype(np.uint8)
    assert np.array_equal(mostly_dark(binary, most_light), expected)
