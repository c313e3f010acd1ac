"""core/maths/perception/frames.py: marker positions in the base frame and the calibrations behind them."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_skills_fakes import TOOL_T_CAMERA, CylModel, rz

from armtree.maths.perception.frames import (
    LinearCorrection,
    camera_in_base,
    estimate_camera_offset,
    eye_to_hand_from_three_positions,
    marker_in_base,
    rodrigues,
    tool_for_camera_over,
    tool_to_marker,
    transform,
)

vec3 = st.lists(st.floats(-300, 300), min_size=3, max_size=3).map(np.array)
rotvec = st.lists(st.floats(-2, 2), min_size=3, max_size=3).map(np.array)


def test_rodrigues_matches_a_rotation_about_z():
    assert np.allclose(rodrigues([0, 0, np.pi / 2]), rz(90)[:3, :3])
    assert np.allclose(rodrigues([0, 0, 0]), np.eye(3))


@given(rotvec)
def test_rodrigues_is_a_rotation(r):
    m = rodrigues(r)
    assert np.allclose(m @ m.T, np.eye(3), atol=1e-9) and np.isclose(np.linalg.det(m), 1.0)


@given(theta=st.floats(-135, 135), p_ca=vec3)
def test_eq18_move_to_the_marker_agrees_with_the_matrix_chain(theta, p_ca):
    base_T_tool = rz(theta)
    base_T_tool[:3, 3] = [150.0, 20.0, 80.0]
    cam = camera_in_base("eye_in_hand", TOOL_T_CAMERA, base_T_tool)
    marker = marker_in_base(cam, None, p_ca)[:3, 3]
    assert np.allclose(
        base_T_tool[:3, 3] + tool_to_marker(base_T_tool, TOOL_T_CAMERA, p_ca), marker
    )


def test_eye_to_hand_camera_pose_is_its_extrinsics():
    fixed = transform([0.1, 0.2, 0.3], [1, 2, 3])
    assert np.allclose(camera_in_base("eye_to_hand", fixed, rz(30)), fixed)
    with pytest.raises(ValueError, match="unknown camera mount"):
        camera_in_base("on_the_wall", fixed, np.eye(4))


def test_eq17_recovers_the_camera_offset_from_touch_tests():
    p_ct_true = -TOOL_T_CAMERA[:3, :3].T @ TOOL_T_CAMERA[:3, 3]
    rng = np.random.default_rng(1)
    p_ca, tools, p_0a = [], [], []
    for _ in range(5):
        tool = rz(rng.uniform(-90, 90))
        tool[:3, 3] = rng.uniform([100, -100, 50], [250, 100, 150])
        marker = rng.uniform([100, -100, -10], [250, 100, 10])
        cam = tool @ TOOL_T_CAMERA
        p_ca.append(np.linalg.inv(cam)[:3, :3] @ marker + np.linalg.inv(cam)[:3, 3])
        tools.append(tool)
        p_0a.append(marker)
    est = estimate_camera_offset(p_ca, tools, p_0a, TOOL_T_CAMERA[:3, :3])
    assert np.allclose(est, p_ct_true)
    with pytest.raises(ValueError):
        estimate_camera_offset([], [], [], np.eye(3))


@settings(max_examples=50, deadline=None)  # a loaded machine can take 200 ms for one example
@given(
    r=rotvec,
    t=vec3,
    g_t_m=st.lists(st.floats(-30, 30), min_size=3, max_size=3),
    a=st.floats(20, 100),
    b=st.floats(20, 100),
)
def test_eqs_1_to_7_recover_the_camera_pose_from_three_marker_positions(r, t, g_t_m, a, b):
    c_T_r = transform(r, t)
    g_t_m = np.array(g_t_m)
    tool0 = np.array([150.0, 0.0, 50.0])
    tools = [tool0, tool0 + [a, 0, 0], tool0 + [a, b, 0]]
    seen = [c_T_r[:3, :3] @ (p + g_t_m) + c_T_r[:3, 3] for p in tools]
    assert np.allclose(eye_to_hand_from_three_positions(seen, tool0, g_t_m), c_T_r, atol=1e-6)


def test_eq8_linear_correction_fits_and_applies():
    rng = np.random.default_rng(2)
    measured = rng.uniform(-100, 100, (20, 3))
    truth = LinearCorrection(1.02, -3.0, 0.98, 1.5)
    fitted = LinearCorrection.fit(measured, truth.apply(measured))
    assert np.allclose([fitted.ax, fitted.bx, fitted.ay, fitted.by], [1.02, -3.0, 0.98, 1.5])
    assert np.allclose(fitted.apply(measured)[:, 2], measured[:, 2])
    with pytest.raises(ValueError):
        LinearCorrection.fit(measured[:1], measured[:1])


@settings(deadline=None)  # the first example compiles; a shared machine may be slow
@given(x=st.floats(150, 250), y=st.floats(-150, 150), h=st.floats(60, 150))
def test_tool_for_camera_over_puts_the_camera_above_the_point(x, y, h):
    model = CylModel()
    point = np.array([x, y, 0.0])
    tool = tool_for_camera_over(model, point, h, TOOL_T_CAMERA, iterations=8)
    cam = model.fk(model.ik(tool)) @ TOOL_T_CAMERA
    assert np.allclose(cam[:3, 3], point + [0, 0, h], atol=1e-3)
