"""Camera calibration on synthetic board views rendered with a known camera, and hand-eye (Durovic 2017)."""

import argparse

import cv2
import numpy as np
import pytest
import yaml

from armtree.api.imaging import load_calibration
from armtree.errors import ConfigError
from armtree.plugins.calibration.command import CalibrateCommand
from armtree.plugins.trackers import synthetic as syn
from armtree.plugins.trackers.calibration import Board, calibrate

K = syn.nominal_camera(fx=600.0)


def parse(argv):
    parser = argparse.ArgumentParser()
    CalibrateCommand().configure(parser)
    return parser.parse_args(argv)


@pytest.fixture(scope="module")
def chessboard_dir(tmp_path_factory):
    folder = tmp_path_factory.mktemp("boards")
    board = Board("chessboard", 9, 7, 25.0)
    for i, view in enumerate(syn.board_views(board.image(40), 225.0, 175.0, K, 7, seed=1)):
        cv2.imwrite(str(folder / f"view{i:02d}.png"), view)
    cv2.imwrite(str(folder / "blank.png"), np.full((480, 640), 128, np.uint8))
    return folder


def test_chessboard_calibration_recovers_the_camera(chessboard_dir, tmp_path, capsys):
    out, plot = tmp_path / "cam.yaml", tmp_path / "cam.png"
    args = parse(
        ["camera", "--images", str(chessboard_dir), "--cols", "9", "--rows", "7",
         "--square-mm", "25", "-o", str(out), "--plot", str(plot)]
    )  # fmt: skip
    assert CalibrateCommand().run(args) == 0
    text = capsys.readouterr().out
    assert "7 of 8 images used" in text and "blank.png: board not found" in text
    intr = load_calibration(out)
    assert intr.camera_matrix[0, 0] == pytest.approx(600.0, rel=0.02)
    assert intr.camera_matrix[1, 1] == pytest.approx(600.0, rel=0.02)
    assert intr.camera_matrix[0, 2] == pytest.approx(319.5, abs=5)
    assert (intr.width, intr.height) == (640, 480)
    data = yaml.safe_load(out.read_text())
    assert data["rms_px"] < 0.3 and len(data["per_image_rms_px"]) == 7
    assert plot.stat().st_size > 10_000 and plot.read_bytes()[:4] == b"\x89PNG"


def test_charuco_calibration():
    board = Board("charuco", 9, 7, 25.0, 18.0, "4x4_50")
    views = syn.board_views(board.image(40), 225.0, 175.0, K, 5, seed=2)
    result = calibrate([(f"v{i}", v) for i, v in enumerate(views)], board)
    assert result.intrinsics.camera_matrix[0, 0] == pytest.approx(600.0, rel=0.02)
    assert result.rms_px < 0.3 and not result.skipped


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--cols", "2", "--rows", "7", "--square-mm", "25"], "at least 3 x 3"),
        (["--cols", "9", "--rows", "7", "--square-mm", "0"], "square-mm"),
        (["--board", "charuco", "--cols", "9", "--rows", "7", "--square-mm", "25"], "marker-mm"),
        (["--cols", "9", "--rows", "7", "--square-mm", "25", "-o", "cam.txt"], ".yaml"),
    ],
)
def test_bad_calibration_options(chessboard_dir, argv, message):
    with pytest.raises(ConfigError, match=message):
        CalibrateCommand().run(parse(["camera", "--images", str(chessboard_dir), *argv]))


def test_too_few_views_and_bad_images(tmp_path):
    cv2.imwrite(str(tmp_path / "a.png"), np.full((48, 64), 128, np.uint8))
    args = ["--cols", "9", "--rows", "7", "--square-mm", "25"]
    with pytest.raises(ConfigError, match="found in 0 image"):
        CalibrateCommand().run(parse(["camera", "--images", str(tmp_path), *args]))
    (tmp_path / "b.png").write_bytes(b"")
    with pytest.raises(ConfigError) as err:
        CalibrateCommand().run(parse(["camera", "--images", str(tmp_path / "b.png"), *args]))
    assert err.value.file.endswith("b.png") and "empty" in err.value.message


def test_kinematics_without_points_is_a_config_error():
    # The kinematic calibration itself is tested in test_calibration_kinematics.py.
    with pytest.raises(ConfigError, match="--points FILE or --simulate N"):
        CalibrateCommand().run(parse(["kinematics"]))


def test_hand_eye_from_three_marker_views(tmp_path, capsys):
    # A camera looking down at the table from 600 mm, turned 20 degrees about its axis.
    a = np.radians(20)
    base_R_cam = np.array([[np.cos(a), np.sin(a), 0], [np.sin(a), -np.cos(a), 0], [0, 0, -1.0]])
    base_T_cam = np.eye(4)
    base_T_cam[:3, :3] = base_R_cam
    base_T_cam[:3, 3] = [220.0, 10.0, 600.0]
    cam_T_base = np.linalg.inv(base_T_cam)
    offset = np.array([0.0, 0.0, 20.0])  # marker 20 mm above the tool centre, facing up
    tools = [
        np.array([180.0, -50.0, 60.0]),
        np.array([280.0, -50.0, 60.0]),
        np.array([280.0, 50.0, 60.0]),
    ]
    marker_R_cam = cam_T_base[:3, :3]  # marker axes = base axes (x forward, z up)
    rvec, _ = cv2.Rodrigues(marker_R_cam)
    paths = []
    for n, tool in enumerate(tools):
        t_cam = (cam_T_base @ np.append(tool + offset, 1.0))[:3]
        placement = syn.Placement(7, 40.0, rvec.reshape(3), t_cam)
        image, _ = syn.render_markers("aruco", [placement], K)
        paths.append(str(tmp_path / f"pos{n}.png"))
        cv2.imwrite(paths[-1], image)
    out = tmp_path / "handeye.yaml"
    args = parse(
        ["hand-eye", "--images", *paths, "--tool-positions", *[",".join(map(str, t)) for t in tools],
         "--marker-offset", "0,0,20", "--size-mm", "40", "--intrinsics", "600,600,319.5,239.5",
         "-o", str(out)]
    )  # fmt: skip
    assert CalibrateCommand().run(args) == 0
    found = np.array(yaml.safe_load(out.read_text())["extrinsics"])
    # Durovic 2017 finds this three-view method fast but coarse: a 0.01 rad error in the
    # axes moves the origin by ~5 mm at 500 mm.
    assert np.abs(found[:3, :3] - base_R_cam).max() < 0.02
    assert np.linalg.norm(found[:3, 3] - base_T_cam[:3, 3]) < 10.0


def test_hand_eye_checks_the_moves(tmp_path):
    cv2.imwrite(str(tmp_path / "x.png"), np.full((48, 64), 128, np.uint8))
    x = str(tmp_path / "x.png")
    args = parse(
        ["hand-eye", "--images", x, x, x, "--tool-positions", "0,0,0", "10,10,0", "10,20,0",
         "--size-mm", "40", "--intrinsics", "600,600,320,240"]
    )  # fmt: skip
    with pytest.raises(ConfigError, match="along the base x axis"):
        CalibrateCommand().run(args)
    args.tool_positions = ["0,0,0", "10,0,0", "10,20,0"]
    with pytest.raises(ConfigError, match="expected one marker"):
        CalibrateCommand().run(args)


def test_live_frames_from_a_profile_camera(chessboard_dir, tmp_path, capsys):
    profile = tmp_path / "rig.yaml"
    profile.write_text(
        "profile: rig\n"
        "arm: {type: dobot_v1, port: sim}\n"
        f"camera: {{type: images, path: {chessboard_dir}, pace: each}}\n"
    )
    argv = ["camera", "--rig", str(profile), "--frames", "4", "--interval", "0",
            "--cols", "9", "--rows", "7", "--square-mm", "25"]  # fmt: skip
    assert CalibrateCommand().run(parse(argv)) == 0
    assert "4 of 4 images used" in capsys.readouterr().out
    argv[4] = "20"
    with pytest.raises(ConfigError, match="recording ended after 7 view"):
        CalibrateCommand().run(parse(argv))
