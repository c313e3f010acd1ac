"""Hand-eye solvers, corrections, camera offsets and kinematic fits: what they find from
synthetic measurements with a known answer, and what they refuse."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.maths.perception.frames import LinearCorrection
from armtree.maths.perception.hand_eye import DegenerateData, MarkerView, lateral_residuals, solve
from armtree.plugins.calibration import fits


def look_down(position):
    pose = np.eye(4)
    pose[:3, :3] = [[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]
    pose[:3, 3] = position
    return pose


CAMERA = look_down([300.0, 0.0, 650.0])
MARKER = np.array([0.0, 0.0, 108.0])


def tool(xyz, yaw=0.0):
    pose = np.eye(4)
    pose[:3, :3] = cv2.Rodrigues(np.array([0.0, 0.0, yaw]))[0]
    pose[:3, 3] = xyz
    return pose


def view(camera, base_T_tool, noise_deg=0.0, rng=None):
    """The marker as the camera at ``camera`` sees it, its direction off by ``noise_deg``."""
    c_T_m = np.linalg.inv(camera) @ base_T_tool
    c_T_m[:3, 3] = (np.linalg.inv(camera) @ base_T_tool @ np.append(MARKER, 1.0))[:3]
    t = c_T_m[:3, 3].copy()
    if noise_deg and rng is not None:
        t[:2] += rng.normal(0.0, np.radians(noise_deg), 2) * t[2]
        t *= 1.0 + rng.normal(0.0, 0.01)  # the distance is worse than the direction
    return MarkerView(base_T_tool, t, cv2.Rodrigues(c_T_m[:3, :3])[0].ravel())


def spread_views(rng, n=15):
    return [
        view(
            CAMERA,
            tool(
                [rng.uniform(200, 420), rng.uniform(-150, 150), rng.uniform(0, 150)],
                rng.uniform(-2, 2),
            ),
            0.03,
            rng,
        )
        for _ in range(n)
    ]


def test_the_marker_directions_find_a_moved_camera_to_a_fraction_of_a_millimetre():
    rng = np.random.default_rng(1)
    true = CAMERA.copy()
    true[:3, :3] = true[:3, :3] @ cv2.Rodrigues(np.radians([0.6, -0.4, 1.0]))[0]
    true[:3, 3] += [5.0, -4.0, 3.0]
    views = [view(true, v.base_T_tool, 0.03, rng) for v in spread_views(rng)]
    fits_found = solve(views, "eye_to_hand", marker_offset=MARKER, guess=CAMERA)
    best = fits_found[0]
    assert best.method == "pnp" and best.rms_mm < 0.5
    # what matters: where it puts a point in the workspace
    probe = np.array([300.0, 50.0, 60.0, 1.0])
    seen_by_true = np.linalg.inv(true) @ probe
    assert np.linalg.norm((best.pose @ seen_by_true)[:3] - probe[:3]) < 1.0
    assert np.linalg.norm((CAMERA @ seen_by_true)[:3] - probe[:3]) > 8.0  # the profile's was off
    others = {f.method: f.degenerate for f in fits_found[1:]}
    assert all(others.values())  # a four-axis arm: OpenCV's methods are not trusted here


def test_seed_000s_three_positions_solve_eqs_1_to_7():
    views = [view(CAMERA, tool(p)) for p in ([250, 0, 50], [290, 0, 50], [290, 40, 50])]
    (fit,) = solve(views, "eye_to_hand", methods=["three_positions"], marker_offset=MARKER)
    np.testing.assert_allclose(fit.pose, CAMERA, atol=1e-6)


@pytest.mark.parametrize(
    ("positions", "reason", "pose"),
    [
        (
            [[250, 0, 50], [290, 5, 50], [290, 45, 50]],
            "not position 0 moved along the base x",
            [290, 5, 50],
        ),
        ([[250, 0, 50], [290, 0, 50], [290, 40, 70]], "moved along the base y axis", [290, 40, 70]),
        ([[250, 0, 50], [255, 0, 50], [255, 40, 50]], "shorter than 10 mm", [255, 0, 50]),
    ],
)
def test_three_positions_that_are_not_seed_000s_moves_are_refused(positions, reason, pose):
    views = [view(CAMERA, tool(p)) for p in positions]
    with pytest.raises(DegenerateData) as info:
        solve(views, "eye_to_hand", methods=["three_positions"], marker_offset=MARKER)
    assert reason in info.value.reason and info.value.pose == pose


def test_unseen_markers_collinear_poses_and_too_few_poses_are_refused():
    rng = np.random.default_rng(2)
    views = spread_views(rng, 8)
    for v in views[3:]:
        v.tvec = None
    with pytest.raises(DegenerateData, match="saw the marker at 3 of 8 poses") as info:
        solve(views, "eye_to_hand", methods=["pnp"], marker_offset=MARKER, guess=CAMERA)
    assert info.value.pose == np.round(views[3].tool_position, 1).tolist()
    line = [view(CAMERA, tool([200 + 20 * k, 10 * k, 50])) for k in range(8)]
    with pytest.raises(DegenerateData, match="lie on a line"):
        solve(line, "eye_to_hand", methods=["pnp"], marker_offset=MARKER, guess=CAMERA)
    with pytest.raises(DegenerateData, match="at least 6 are needed: add poses"):
        solve(
            spread_views(rng, 4), "eye_to_hand", methods=["pnp"], marker_offset=MARKER, guess=CAMERA
        )


def test_eye_in_hand_finds_the_camera_on_the_tool_with_the_marker_on_the_table():
    rng = np.random.default_rng(3)
    tool_T_cam = look_down([10.0, 40.0, 60.0])
    tool_T_cam[:3, 3] = [0.0, 40.0, 60.0]
    marker = np.array([185.0, 10.0, -35.0])
    views = []
    for _ in range(10):
        t = tool(
            [rng.uniform(150, 190), rng.uniform(-30, 10), rng.uniform(0, 30)],
            rng.uniform(-0.3, 0.3),
        )
        cam = t @ tool_T_cam
        p = (np.linalg.inv(cam) @ np.append(marker, 1.0))[:3]
        views.append(MarkerView(t, p, np.zeros(3)))
    guess = tool_T_cam.copy()
    guess[:3, 3] += [3.0, -2.0, 0.0]
    best = solve(views, "eye_in_hand", methods=["pnp"], guess=guess, marker_z=-35.0)[0]
    np.testing.assert_allclose(best.pose[:3, 3], tool_T_cam[:3, 3], atol=0.05)
    np.testing.assert_allclose(best.marker, marker, atol=0.05)


@settings(max_examples=30, deadline=None)
@given(
    st.lists(st.floats(-200, 200), min_size=3, max_size=3),
    st.lists(st.floats(-200, 200), min_size=3, max_size=3),
    st.floats(200, 900),
)
def test_lateral_residuals_ignore_the_distance_along_the_line_of_sight(p, shift, depth):
    point = np.array([p[0], p[1], depth])
    farther = point * 1.3  # the same direction from the camera
    np.testing.assert_allclose(lateral_residuals(point[None], farther[None]), 0.0, atol=1e-6)
    moved = point + np.array([shift[0], shift[1], 0.0])
    assert lateral_residuals(moved[None], point[None])[0] == pytest.approx(
        np.hypot(*shift[:2]), rel=1e-6, abs=1e-6
    )


def test_a_correction_is_kept_only_when_it_lowers_the_held_out_error():
    rng = np.random.default_rng(4)
    truth = np.column_stack([rng.uniform(200, 300, 100), rng.uniform(-50, 50, 100), np.zeros(100)])
    biased = LinearCorrection(1.02, -5.0, 0.99, 3.0).inverse(truth) + rng.normal(0, 0.1, (100, 3))
    before, after = fits.cross_validated(biased, truth, 5)
    assert before.mean() > 3.0 and after.mean() < 0.3
    noise = truth + rng.normal(0, 0.2, (100, 3))  # nothing to correct: held-out gets worse
    before, after = fits.cross_validated(noise, truth, 5)
    assert after.mean() >= before.mean()


def test_folds_cover_every_point_once():
    folds = fits.folds_of(23, 5)
    assert sorted(np.concatenate(folds).tolist()) == list(range(23)) and len(folds) == 5
