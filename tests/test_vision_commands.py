"""``armtree markers`` and ``armtree detect``, the registrations, and the detection rate (Showers 2016 eq. 15)."""

import argparse
import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

from armtree.api.rig import Frame
from armtree.errors import ConfigError
from armtree.hooks.plugin_manager import make_plugin_manager
from armtree.plugins.trackers import synthetic as syn
from armtree.plugins.trackers.commands import DetectCommand, MarkersCommand, parse_ids
from armtree.plugins.trackers.detection_rate import marker_detection_rate
from armtree.plugins.trackers.hamming import HammingTracker

K = syn.nominal_camera()
#: Valid Hampy ids (a unique orientation; the shipped profiles' ducky, duckybot and a trash).
H1, H2, H3 = 69937, 69975, 70026


def parse(command, argv):
    parser = argparse.ArgumentParser()
    command.configure(parser)
    return parser.parse_args(argv)


def run(command, argv):
    return command.run(parse(command, argv))


def test_plugins_register_trackers_cameras_and_commands():
    registry = make_plugin_manager().registry
    assert {"aruco", "hamming"} <= set(registry.names("tracker"))
    assert {"opencv", "video", "images"} <= set(registry.names("camera"))
    assert {"detect", "markers", "calibrate"} <= set(registry.names("command"))
    for name in ("aruco", "hamming"):
        assert registry.get("tracker", name).params, "factories declare PARAMS"


@pytest.mark.parametrize(("family", "marker_id"), [("aruco", 7), ("hamming", 228337701)])
def test_printed_marker_has_its_size_and_reads_back(tmp_path, family, marker_id, capsys):
    out = tmp_path / "m.png"
    assert (
        run(
            MarkersCommand(),
            ["--family", family, "--id", str(marker_id), "--size-mm", "30", "-o", str(out)],
        )
        == 0
    )
    from PIL import Image

    with Image.open(out) as im:
        assert im.info["dpi"][0] == pytest.approx(300, abs=0.01)
        side = 30 / 25.4 * 300
        cells = 6 if family == "aruco" else 9
        assert im.size[0] == pytest.approx(side * (1 + 2 / cells), abs=2), (
            "square plus one-cell quiet zone"
        )
    capsys.readouterr()
    assert run(DetectCommand(), [str(out), "--tracker", family, "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert [d["id"] for d in record["detections"]] == [marker_id]


def test_sheets_png_and_pdf(tmp_path):
    pdf = tmp_path / "s.pdf"
    assert (
        run(
            MarkersCommand(),
            [
                "--family",
                "hamming",
                "--sheet",
                f"{H1},{H2},{H3}",
                "--size-mm",
                "30",
                "-o",
                str(pdf),
            ],
        )
        == 0
    )
    assert pdf.read_bytes()[:4] == b"%PDF"
    png = tmp_path / "s.png"
    assert (
        run(
            MarkersCommand(),
            ["--family", "aruco", "--sheet", "0-3,9", "--dpi", "100", "-o", str(png)],
        )
        == 0
    )
    image = cv2.imread(str(png))
    assert np.allclose(image.shape[:2], (297 / 25.4 * 100, 210 / 25.4 * 100), atol=1), (
        "A4 at 100 dpi"
    )
    assert parse_ids("0-3,9") == [0, 1, 2, 3, 9]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--family", "aruco", "--id", "1", "--size-mm", "0", "-o", "m.png"], "positive"),
        (
            ["--family", "aruco", "--id", "1", "--dictionary", "4x4_500", "-o", "m.png"],
            "did you mean",
        ),
        (["--family", "aruco", "--id", "50", "-o", "m.png"], "ids 0 to 49"),
        (["--family", "hamming", "--id", str(2**28), "-o", "m.png"], "2\\*\\*28"),
        (["--family", "hamming", "--id", str(H1), "-o", "m.jpg"], ".png"),
        (["--family", "hamming", "-o", "m.png"], "--id N"),
        (["--family", "hamming", "--sheet", "5-1", "-o", "m.pdf"], "ids like"),
        (
            ["--family", "aruco", "--sheet", "0-40", "--size-mm", "30", "-o", "m.png"],
            "write a .pdf",
        ),
    ],
)
def test_markers_bad_options(tmp_path, monkeypatch, argv, message):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match=message):
        run(MarkersCommand(), argv)


@pytest.fixture
def frames_dir(tmp_path):
    placements = []
    for i, (x, y) in enumerate([(-60.0, -20.0), (0.0, 30.0), (60.0, -20.0)]):
        rvec, tvec = syn.look_at_pose(300.0, 10.0 * i, 40.0 * i, (x, y))
        placements.append(syn.Placement((H1, H2, H3)[i], 25.0, rvec, tvec))
    image, truth = syn.render_markers("hamming", placements, K)
    cv2.imwrite(str(tmp_path / "three.png"), image)
    cv2.imwrite(str(tmp_path / "none.png"), np.full((480, 640), 200, np.uint8))
    return tmp_path, truth


def test_detect_json_with_poses_and_annotations(frames_dir, capsys):
    folder, truth = frames_dir
    argv = [str(folder / "three.png"), str(folder / "none.png"), "--tracker", "hamming", "--json",
            "--size-mm", "25", "--intrinsics", f"{K[0, 0]},{K[1, 1]},{K[0, 2]},{K[1, 2]}",
            "--annotate", str(folder / "out")]  # fmt: skip
    assert run(DetectCommand(), argv) == 0
    records = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["path"] for r in records] == [str(folder / "three.png"), str(folder / "none.png")]
    dets = {d["id"]: d for d in records[0]["detections"]}
    assert set(dets) == {H1, H2, H3} and records[1]["detections"] == []
    for marker_id, d in dets.items():
        assert np.abs(np.array(d["corners"]) - truth[marker_id]).max() < 0.5
        assert d["tvec"][2] == pytest.approx(300.0, abs=5.0) and len(d["rvec"]) == 3
    drawn = cv2.imread(str(folder / "out" / "three.png"))
    assert drawn.shape == (480, 640, 3)
    assert not np.array_equal(drawn, cv2.imread(str(folder / "three.png")))


def test_detect_plain_text(frames_dir, capsys):
    folder, _ = frames_dir
    assert run(DetectCommand(), [str(folder / "three.png"), "--tracker", "hamming"]) == 0
    out = capsys.readouterr().out
    assert "3 marker(s)" in out and f"id {H2}" in out


@pytest.mark.parametrize(
    ("files", "extra", "message"),
    [
        (["missing.png"], [], "no such image"),
        (["empty.png"], [], "empty file"),
        (["text.png"], [], "cannot read as an image"),
        (["."], [], "folder"),
        (["three.png"], ["--tracker", "hamming", "--dictionary", "4x4_50"], "aruco and apriltag"),
        (["three.png"], ["--tracker", "apriltag", "--dictionary", "37h11"], "16h5, 25h9"),
        (["three.png"], ["--dictionary", "4x4_5O"], "did you mean '4x4_50'"),
        (["three.png"], ["--tracker", "hamm"], "did you mean 'hamming'"),
        (["three.png"], ["--size-mm", "0"], "positive"),
        (["three.png"], ["--intrinsics", "800,800,320"], "4 comma-separated"),
        (["three.png"], ["--threshold", "40"], "between 0 and 1"),
        (["three.png"], ["--rate"], "--fps"),
    ],
)
def test_detect_bad_input(frames_dir, monkeypatch, files, extra, message):
    folder, _ = frames_dir
    (folder / "empty.png").write_bytes(b"")
    (folder / "text.png").write_text("hello")
    monkeypatch.chdir(folder)
    with pytest.raises(ConfigError, match=message) as err:
        run(DetectCommand(), [*files, *extra])
    if "image" in message or message in ("empty file", "folder"):
        assert err.value.file == files[0]


def test_detect_rate_on_a_video(tmp_path, capsys):
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 20, (640, 480))
    for i in range(10):
        rvec, tvec = syn.look_at_pose(300.0, 0.0, 0.0, (-40.0 + 8 * i, 0.0))
        image, _ = syn.render_markers(
            "aruco", [syn.Placement(3, 25.0, rvec, tvec)], K, background=200.0
        )
        if i in (4, 5):
            image[:] = 200  # marker out of view in two frames
        writer.write(cv2.cvtColor(image, cv2.COLOR_GRAY2BGR))
    writer.release()
    assert run(DetectCommand(), [str(path), "--rate", "--marker-id", "3", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    # Showers 2016 eq. 15: 8 detections in 10 frames at 20 fps
    assert (result["frames"], result["detections"], result["fps"]) == (10, 8, 20.0)
    assert result["mdr"] == pytest.approx(16.0)


def test_detection_rate_function_counts_one_marker():
    rvec, tvec = syn.look_at_pose(300.0)
    image, _ = syn.render_markers("hamming", [syn.Placement(H1, 25.0, rvec, tvec)], K)
    frames = [Frame(image, 0.0, K, np.zeros(5))] * 3 + [
        Frame(np.full_like(image, 90), 0.0, K, np.zeros(5))
    ]
    rate = marker_detection_rate(HammingTracker(), frames, 20.0, marker_id=H1)
    assert (rate.frames, rate.detections, rate.rate) == (4, 3, 15.0)
    assert marker_detection_rate(HammingTracker(), frames, 20.0, marker_id=H2).rate == 0.0
    with pytest.raises(ValueError):
        marker_detection_rate(HammingTracker(), frames, 0.0)


def test_cli_exit_codes(frames_dir):
    folder, _ = frames_dir
    (folder / "text.png").write_text("hello")
    bad = subprocess.run(
        [sys.executable, "-m", "armtree.cli", "detect", str(folder / "text.png")],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert bad.returncode == 2 and "text.png" in bad.stderr and "Traceback" not in bad.stderr
    good = subprocess.run(
        [sys.executable, "-m", "armtree.cli", "detect", "--tracker", "hamming", "--json", str(folder / "three.png")],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert good.returncode == 0, good.stderr
    assert len(json.loads(good.stdout)["detections"]) == 3
    later = subprocess.run(
        [sys.executable, "-m", "armtree.cli", "calibrate", "kinematics"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert later.returncode == 2 and "--points FILE or --simulate N" in later.stderr


def test_detect_takes_tracker_and_tags_from_a_profile(frames_dir, capsys):
    folder, _ = frames_dir
    profile = folder / "rig.yaml"
    profile.write_text(
        "profile: rig\n"
        "arm: {type: dobot_v1, port: sim}\n"
        "tracker: {type: hamming, preprocess: {adaptive: true}}\n"
        f"tags: {{ducky: {{id: {H1}, size_mm: 25}}, trash: {{ids: [{H3}], size_mm: 30}}}}\n"
    )
    argv = [str(folder / "three.png"), "--rig", str(profile), "--tracker", "hamming", "--json",
            "--intrinsics", f"{K[0, 0]},{K[1, 1]},{K[0, 2]},{K[1, 2]}"]  # fmt: skip
    assert run(DetectCommand(), argv) == 0
    dets = {d["id"]: d for d in json.loads(capsys.readouterr().out)["detections"]}
    assert (dets[H1]["role"], dets[H1]["size_mm"]) == ("ducky", 25.0)
    assert (dets[H3]["role"], dets[H3]["size_mm"]) == ("trash", 30.0)
    assert dets[H2]["role"] == "unknown" and dets[H2]["tvec"] is None
    assert dets[H3]["tvec"][2] == pytest.approx(360.0, abs=6.0), "a 25 mm marker taken as 30 mm"


@pytest.mark.parametrize("scale", [1, 2])
def test_detect_with_a_rig_takes_the_profiles_camera_intrinsics(
    frames_dir, tmp_path, capsys, scale
):
    folder, truth = frames_dir
    # the profile's camera was calibrated at 640x480; a half-size image scales its intrinsics
    image = cv2.imread(str(folder / "three.png"))
    small = cv2.resize(image, (640 // scale, 480 // scale), interpolation=cv2.INTER_AREA)
    cv2.imwrite(str(tmp_path / "shot.png"), small)
    profile = tmp_path / "rig.yaml"
    profile.write_text(
        "profile: rig\n"
        "arm: {type: dobot_v1, port: sim}\n"
        "camera: {type: sim, width: 640, height: 480,\n"
        f"         intrinsics: {{fx: {K[0, 0]}, fy: {K[1, 1]}, cx: {K[0, 2]}, cy: {K[1, 2]}}}}}\n"
        "tracker: {type: hamming}\n"
        f"tags: {{ducky: {{ids: [{H1}, {H2}, {H3}], size_mm: 25}}}}\n"
    )
    argv = [str(tmp_path / "shot.png"), "--rig", str(profile), "--tracker", "hamming", "--json"]
    assert run(DetectCommand(), argv) == 0
    dets = json.loads(capsys.readouterr().out)["detections"]
    assert {d["id"] for d in dets} == {H1, H2, H3}
    for d in dets:
        assert d["tvec"] is not None, "the profile's intrinsics give every marker a pose"
        assert d["tvec"][2] == pytest.approx(300.0, abs=8.0)
