"""Calibration files a profile includes, the ``calibration:`` section, and the simulation's
as-built rig and measuring device that calibrations are judged by."""

from __future__ import annotations

import textwrap
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

import armtree
from armtree.api.clock import VirtualClock
from armtree.config.calibration import calibration_of, update_calibration_file
from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.plugins.sim.rig_world import sim_world
from armtree.runtime.rig_builder import build_rig

PROFILE = """\
profile: bench
arm: {type: vicra, port: sim}
camera: {type: sim, mount: eye_to_hand, position: [300, 0, 650], look_at: [300, 0, 0],
         width: 320, height: 240}
include: cal.yaml
"""


def write(path, text):
    path.write_text(textwrap.dedent(text))
    return path


def test_an_included_file_lays_its_sections_over_the_profile(tmp_path):
    write(tmp_path / "bench.yaml", PROFILE)
    pose = np.eye(4)
    pose[:3, 3] = [301, 2, 649]
    update_calibration_file(
        tmp_path / "cal.yaml",
        {"camera": {"extrinsics": pose.tolist()}},
        ("hand_eye", {"residual_rms_mm": 0.4}),
    )
    update_calibration_file(
        tmp_path / "cal.yaml",
        {"calibration": {"vision_correction": {"ax": 1.01, "bx": -2.0, "ay": 0.99, "by": 1.5}}},
    )
    profile = armtree.load_profile(tmp_path / "bench.yaml")
    camera = profile.data["camera"]
    assert camera["extrinsics"] == pose.tolist() and camera["width"] == 320  # kept
    cal = calibration_of(profile)
    assert cal.arm is None and cal.vision is not None
    np.testing.assert_allclose(cal.seen(np.array([100.0, 100.0, 5.0])), [99.0, 100.5, 5.0])
    records = profile.data["calibration"]["records"]
    assert records["hand_eye"]["residual_rms_mm"] == 0.4 and "date" in records["hand_eye"]
    # --set still wins over an included file
    again = armtree.load_profile(tmp_path / "bench.yaml", ["camera.width=640"])
    assert again.data["camera"]["width"] == 640
    assert again.data["camera"]["extrinsics"] == pose.tolist()


def test_an_error_in_an_included_file_names_that_file(tmp_path):
    write(tmp_path / "bench.yaml", PROFILE)
    write(
        tmp_path / "cal.yaml",
        """\
        calibration:
          vision_correction: {ax: 1.0, bx: 0, ay: 7, by: 0}
        """,
    )
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile(tmp_path / "bench.yaml")
    err = info.value.errors[0]
    assert err.file.endswith("cal.yaml") and (err.line, err.column) == (2, 43)
    assert "calibration.vision_correction.ay: expected a scale within 0.5 to 2" in err.message


@pytest.mark.parametrize(
    ("extra", "cal", "message"),
    [
        ("", None, "bench.yaml:5:10: include: no file 'cal.yaml' beside bench.yaml"),
        ("", "profile: other\n", "cal.yaml:1:1: profile: an included file may not set it"),
        ("", "- 1\n", "an included file must be a mapping of profile sections"),
        ("", "calibration: {offsets: 1}\n", "cal.yaml:1:15: calibration: unknown key 'offsets'"),
        ("include2: 1\n", "{}\n", "bench.yaml:6:1: unknown profile section 'include2'"),
    ],
)
def test_bad_includes_are_refused_where_they_are_written(tmp_path, extra, cal, message):
    write(tmp_path / "bench.yaml", PROFILE + extra)
    if cal is not None:
        (tmp_path / "cal.yaml").write_text(cal)
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile(tmp_path / "bench.yaml")
    assert any(message in e.format() for e in info.value.errors), [
        e.format() for e in info.value.errors
    ]


def test_set_include_names_a_file_in_the_working_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    update_calibration_file(
        "mine.yaml", {"calibration": {"arm_correction": {"ax": 1, "bx": 2, "ay": 1, "by": 0}}}
    )
    profile = armtree.load_profile("sim_vicra", ["include=mine.yaml"])
    assert calibration_of(profile).command_for(np.array([300.0, 0.0, 50.0]))[0] == 298.0
    assert "include: mine.yaml" in (tmp_path / "mine.yaml").read_text()  # says how to use it
    assert yaml.safe_load((tmp_path / "mine.yaml").read_text())["calibration"]["arm_correction"]


def sim_rig(*overrides: str, profile: str = "sim_vicra"):
    clock = VirtualClock()
    rig = build_rig(armtree.load_profile(profile, list(overrides)), get_plugin_manager(), clock)
    rig.start()
    return rig, clock


def look(rig, clock):
    for _ in range(100):
        rig.step(clock.advance(0.05))
        frame = rig.camera.read()
        if frame is not None:
            return {d.id: d for d in rig.tracker.detect(frame)}
    raise AssertionError("no frame")


def test_an_as_built_camera_is_not_where_the_profile_says(tmp_path):
    offset = "world.as_built={camera: {offset_mm: [6, -4, 0], rotation_deg: [0, 0, 1.0]}}"
    rig, clock = sim_rig(offset)
    try:
        truth = sim_world(SimpleNamespace(rig=rig)).bodies["ducky"].top_pose()[:3, 3]
        believed = rig.camera.extrinsics @ np.append(look(rig, clock)[0].tvec, 1.0)
        assert np.linalg.norm(believed[:2] - truth[:2]) > 6.0  # the skills would be off
        true_pose = rig.camera.mounted
        seen = true_pose @ np.append(look(rig, clock)[0].tvec, 1.0)
        assert np.linalg.norm(seen[:2] - truth[:2]) < 1.5  # the camera itself is fine
    finally:
        rig.close()
    # a calibrated pose in the profile is what the skills take
    rig, clock = sim_rig(offset, f"camera.extrinsics={true_pose.tolist()}")
    try:
        np.testing.assert_allclose(rig.camera.extrinsics, true_pose)
    finally:
        rig.close()


def test_an_as_built_arm_and_the_simulated_measuring_device():
    rig, clock = sim_rig(
        "world.as_built={arm: {tool_offset_mm: 48}}", profile="sim_dobot_eye_to_hand"
    )
    try:
        handle = rig.arm.move_to(np.array([170.0, 30.0, 5.0]))
        while not handle.done:
            rig.step(clock.advance(0.05))
        device = rig.reference
        assert "simulated measuring device" in device.description
        reads = np.array([device.tool_position().value for _ in range(20)])
        # the arm believes its tool is at (170, 30); the real tool is 7 mm further in
        reach = np.hypot(*reads[:, :2].mean(axis=0))
        assert reach == pytest.approx(np.hypot(170, 30) - 7.0, abs=0.2)
        assert 0.03 < reads[:, 0].std() < 0.3  # a reading error, not the truth itself
        placed = device.place_marker(9, np.array([160.0, -20.0]))
        assert placed.done and placed.error is None
        np.testing.assert_allclose(device.marker_position(9).value[:2], [160, -20], atol=0.6)
        assert device.marker_position(42).error == "no marker 42 in the simulated world"
    finally:
        rig.close()


@pytest.mark.parametrize(
    ("override", "message"),
    [
        (
            "world.as_built={arm: {tool_ofset_mm: 48}}",
            "the dobot_v1 arm has no key 'tool_ofset_mm'",
        ),
        (
            "world.as_built={camera: {offset_mm: [1, 2]}}",
            "world.as_built.camera.offset_mm: expected three",
        ),
        ("world.as_built={lens: 1}", "world.as_built.lens: unknown key"),
        ("world.reference={noise_mm: -1}", "world.reference.noise_mm: expected a reading error"),
    ],
)
def test_a_bad_as_built_section_is_refused(override, message):
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile("sim_dobot_eye_to_hand", [override])
    assert any(message in e.message for e in info.value.errors), [
        e.message for e in info.value.errors
    ]
