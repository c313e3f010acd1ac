"""Moller's triangle-triangle test: batched == plain-Python reference == an independent test."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from armtree.maths.motion.tritri import intersect_matrix, intersect_pairs, triangles_intersect


def _segment_hits_triangle(p, q, t):
    """Moller-Trumbore segment/triangle test, an algorithm independent of the one under test."""
    e1, e2, d = t[1] - t[0], t[2] - t[0], q - p
    h = np.cross(d, e2)
    det = e1 @ h
    if abs(det) < 1e-12:
        return False
    s = p - t[0]
    u = (s @ h) / det
    qq = np.cross(s, e1)
    v = (d @ qq) / det
    w = (e2 @ qq) / det
    return u >= 0 and v >= 0 and u + v <= 1 and 0 <= w <= 1


def _independent(a, b):
    # Two non-coplanar triangles meet iff an edge of one crosses the other.
    return any(_segment_hits_triangle(a[i], a[(i + 1) % 3], b) for i in range(3)) or any(
        _segment_hits_triangle(b[i], b[(i + 1) % 3], a) for i in range(3)
    )


def test_batched_matches_reference_and_independent_test_on_random_pairs():
    rng = np.random.default_rng(1)
    a = rng.uniform(0, 1, (3000, 3, 3))
    b = rng.uniform(0, 1, (3000, 3, 3)) + 0.25
    fast = intersect_pairs(a, b)
    ref = np.array([triangles_intersect(x, y) for x, y in zip(a, b, strict=True)])
    other = np.array([_independent(x, y) for x, y in zip(a, b, strict=True)])
    assert 0.05 < fast.mean() < 0.95  # both outcomes well represented
    np.testing.assert_array_equal(fast, ref)
    np.testing.assert_array_equal(fast, other)


def test_matrix_layout_matches_pairs():
    rng = np.random.default_rng(2)
    a = rng.uniform(0, 1, (70, 3, 3))
    b = rng.uniform(0, 1, (90, 3, 3)) + 0.2
    m = intersect_matrix(a, b, chunk=1000)
    ia, ib = np.meshgrid(np.arange(70), np.arange(90), indexing="ij")
    np.testing.assert_array_equal(m, intersect_pairs(a[ia.ravel()], b[ib.ravel()]).reshape(70, 90))
    assert m.any() and not m.all()


@pytest.mark.parametrize(
    ("shift", "expected"),
    [
        ([0.2, 0.2, 0.0], True),
        ([2.0, 0.0, 0.0], False),
        ([1.0, 0.0, 0.0], True),
        ([0.6, 0.6, 0.0], False),
    ],
)
def test_coplanar_triangles(shift, expected):
    t1 = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    t2 = t1 + shift
    assert triangles_intersect(t1, t2) is expected
    assert bool(intersect_pairs(t1[None], t2[None])[0]) is expected


def test_coplanar_containment_and_touching_vertex():
    big = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0.0]])
    small = np.array([[1, 1, 0], [2, 1, 0], [1, 2, 0.0]])
    assert triangles_intersect(big, small) and triangles_intersect(small, big)
    # Crossing planes, touching at one vertex only.
    up = np.array([[0, 0, 0], [0, 0, 1], [-1, 0, 1.0]])
    assert triangles_intersect(big, up)
    assert intersect_pairs(np.stack([big, big]), np.stack([small, up])).all()


def test_piercing_and_parallel_planes():
    flat = np.array([[0, 0, 0], [4, 0, 0], [0, 4, 0.0]])
    pierce = np.array([[1, 1, -1], [1, 1, 1], [1.5, 1, 1.0]])
    parallel = flat + [0, 0, 1e-3]
    assert triangles_intersect(flat, pierce)
    assert not triangles_intersect(flat, parallel)
    np.testing.assert_array_equal(
        intersect_pairs(np.stack([flat, flat]), np.stack([pierce, parallel])), [True, False]
    )


coord = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
triangle = st.lists(st.lists(coord, min_size=3, max_size=3), min_size=3, max_size=3)


@settings(max_examples=300, deadline=None)
@given(triangle, triangle)
def test_property_batched_equals_reference(t1, t2):
    a, b = np.array(t1), np.array(t2)
    # Triangles of zero area are not triangles (meshes drop them when they load).
    for t in (a, b):
        assume(np.linalg.norm(np.cross(t[1] - t[0], t[2] - t[0])) > 1e-6)
    assert bool(intersect_pairs(a[None], b[None])[0]) == triangles_intersect(a, b)
    # The test is symmetric in its two arguments.
    assert triangles_intersect(a, b) == triangles_intersect(b, a)
