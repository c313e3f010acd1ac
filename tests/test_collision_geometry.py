"""Transforms and box geometry (armtree.maths.motion.geometry): properties over random poses."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.maths.motion.geometry import (
    apply,
    box_corners,
    box_triangles,
    from_rpy_deg,
    invert,
    rot_z,
    transform,
)

angles = st.lists(st.floats(-360, 360, allow_nan=False), min_size=3, max_size=3)
vec = st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=3, max_size=3)


@settings(max_examples=100, deadline=None)
@given(angles, vec)
def test_property_rigid_transforms_invert_and_preserve_lengths(rpy, t):
    rot = from_rpy_deg(np.array(rpy))
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rot) > 0
    pose = transform(rot, np.array(t))
    np.testing.assert_allclose(invert(pose) @ pose, np.eye(4), atol=1e-9)
    pts = np.array([[1.0, 2.0, 3.0], [-4.0, 0.5, 2.0]])
    moved = apply(pose, pts)
    assert np.isclose(np.linalg.norm(moved[0] - moved[1]), np.linalg.norm(pts[0] - pts[1]))


def test_rpy_order_is_yaw_pitch_roll_about_fixed_axes():
    np.testing.assert_allclose(
        from_rpy_deg(np.array([0.0, 0.0, 90.0])), rot_z(np.pi / 2), atol=1e-12
    )
    np.testing.assert_allclose(
        from_rpy_deg(np.array([90.0, 0.0, 0.0])) @ [0, 1, 0], [0, 0, 1], atol=1e-12
    )


@settings(max_examples=50, deadline=None)
@given(angles, vec, st.lists(st.floats(0.1, 50), min_size=3, max_size=3))
def test_property_box_triangles_are_the_outward_surface(rpy, t, size):
    pose = transform(from_rpy_deg(np.array(rpy)), np.array(t))
    size = np.array(size)
    corners = box_corners(pose, size)
    tris = box_triangles(pose, size)
    assert tris.shape == (12, 3, 3)
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    outward = np.einsum("ij,ij->i", normals, tris.mean(axis=1) - pose[:3, 3])
    assert np.all(outward > 0)
    area = 0.5 * np.linalg.norm(normals, axis=1).sum()
    assert np.isclose(area, 2 * (size[0] * size[1] + size[1] * size[2] + size[0] * size[2]))
    np.testing.assert_allclose(corners.mean(axis=0), pose[:3, 3], atol=1e-9)
