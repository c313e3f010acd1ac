"""What was made faster gives the same bits as the plain way of computing it."""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.plugins.sim.renderer import _noise_bank


def _plain_noise_bank(rng: np.random.Generator, shape: tuple[int, ...], sigma: float) -> list:
    """The bank as first written: each image drawn with ``normal`` and clipped, rounded to uint8."""
    bank = []
    for _ in range(6 if sigma > 0 else 0):
        n = rng.normal(0, sigma, shape)
        pos = np.clip(np.rint(n), 0, 255).astype(np.uint8)
        neg = np.clip(np.rint(-n), 0, 255).astype(np.uint8)
        bank.append((pos, neg))
    return bank


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    sigma=st.one_of(st.just(0.0), st.floats(0.05, 400.0)),
    h=st.integers(1, 24),
    w=st.integers(1, 24),
)
def test_noise_bank_draws_the_plain_bank_bit_for_bit(seed, sigma, h, w):
    shape = (h, w, 3)
    fast = _noise_bank(np.random.default_rng([seed, 7]), shape, sigma)
    plain = _plain_noise_bank(np.random.default_rng([seed, 7]), shape, sigma)
    assert len(fast) == len(plain) == (6 if sigma > 0 else 0)
    for (pos, neg), (pos0, neg0) in zip(fast, plain, strict=True):
        assert pos.dtype == neg.dtype == np.uint8
        assert np.array_equal(pos, pos0)
        assert np.array_equal(neg, neg0)


def test_noise_bank_leaves_the_generator_where_the_plain_bank_does():
    # What the renderer draws next from the same generator must not move.
    fast, plain = np.random.default_rng([5, 7]), np.random.default_rng([5, 7])
    _noise_bank(fast, (9, 11, 3), 3.0)
    _plain_noise_bank(plain, (9, 11, 3), 3.0)
    assert fast.integers(2**62) == plain.integers(2**62)


def test_rounding_of_halves_matches_the_uint8_conversion():
    # Halves round to even in both: 0.5 -> 0, 1.5 -> 2, 2.5 -> 2, -0.5 -> 0.
    n = np.array([[[0.5, 1.5, 2.5]], [[-0.5, -1.5, 255.5]]])
    assert np.array_equal(cv2.add(n, 0.0, dtype=cv2.CV_8U), np.clip(np.rint(n), 0, 255))
