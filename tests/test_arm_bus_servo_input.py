"""Bad input to a bus-servo arm: a clear error, placed, and nothing moves.

A URDF that does not parse, no chain to the tool link, a joint without limits, a
missing mesh, servo ids given twice, a baud rate the servos do not run at, a
calibration file of other servos: each is exit 2 with ``FILE:LINE:COL``. A servo that
does not answer on the bus is exit 3 naming the device and the servo.
"""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

import armtree
from armtree.config.resolve import resolve

BIN = Path(sys.executable).parent
console = pytest.mark.skipif(
    not (BIN / "armtree").exists(), reason="the armtree console scripts are not installed"
)

PROFILE = """\
profile: mine
arm:
  type: bus_servo
  port: sim
  bus: feetech
  baud: {baud}
  urdf: {urdf}
  tool_link: {tool}
  home: [0, -28, 29, 89, 0]
  servos:
    shoulder_pan: {{id: 1, model: sts3215}}
    shoulder_lift: {{id: 2, model: sts3215}}
    elbow_flex: {{id: {elbow}, model: sts3215}}
    wrist_flex: {{id: 4, model: sts3215}}
    wrist_roll: {{id: 5, model: sts3215}}
  gripper: {{id: 6, model: sts3215}}
{extra}"""


def write_profile(tmp_path: Path, *, urdf="arm.urdf", tool="tcp", baud=1000000, elbow=3, extra=""):
    if urdf == "arm.urdf" and not (tmp_path / urdf).exists():
        shutil.copy(resolve("so101.urdf", "profile"), tmp_path / urdf)
    path = tmp_path / "mine.yaml"
    text = PROFILE.format(urdf=urdf, tool=tool, baud=baud, elbow=elbow, extra=extra)
    path.write_text(text)
    return path


def errors(path: Path, cwd: Path, monkeypatch) -> list[armtree.ConfigError]:
    monkeypatch.chdir(cwd)
    with pytest.raises(armtree.ConfigError) as caught:
        armtree.load_profile(str(path))
    return caught.value.errors


def urdf_edited(tmp_path: Path, old: str, new: str) -> None:
    text = resolve("so101.urdf", "profile").read_text()
    assert old in text
    (tmp_path / "arm.urdf").write_text(text.replace(old, new, 1))


def line_of(path: Path, needle: str) -> int:
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1) if needle in line)


def test_a_profile_pointing_at_the_shipped_urdf_makes_an_arm(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    profile = armtree.load_profile(str(write_profile(tmp_path)))
    model = profile.manager.registry.get("arm", "bus_servo").factory.model(profile.component("arm"))
    assert [j.name for j in model.joints][:2] == ["shoulder_pan", "shoulder_lift"]


def test_a_urdf_arm_without_a_home_pose_is_told_to_give_one(tmp_path, monkeypatch):
    path = write_profile(tmp_path)
    path.write_text(path.read_text().replace("  home: [0, -28, 29, 89, 0]\n", ""))
    (exc,) = errors(path, tmp_path, monkeypatch)
    assert "arm.home: give the home pose, 5 joint angles (deg)" in exc.message


def test_a_urdf_that_does_not_parse(tmp_path, monkeypatch):
    urdf_edited(tmp_path, '<link name="shoulder">', '<link name="shoulder"')
    (exc,) = errors(write_profile(tmp_path), tmp_path, monkeypatch)
    assert exc.file.endswith("arm.urdf") and exc.line is not None and exc.column is not None
    assert "not a URDF" in exc.message


def test_no_chain_to_the_named_tool_link(tmp_path, monkeypatch):
    urdf_edited(tmp_path, '<link name="tcp"/>', '<link name="tcp"/>\n  <link name="camera"/>')
    (exc,) = errors(write_profile(tmp_path, tool="camera"), tmp_path, monkeypatch)
    assert (exc.file, exc.line) == (
        str(tmp_path / "arm.urdf"),
        line_of(tmp_path / "arm.urdf", '"camera"'),
    )
    assert "no chain of moving joints leads to the tool link 'camera'" in exc.message


def test_a_joint_without_limits(tmp_path, monkeypatch):
    urdf_edited(
        tmp_path,
        '<limit lower="-1.69" upper="1.69" velocity="1.5" effort="10"/>',
        "",
    )
    (exc,) = errors(write_profile(tmp_path), tmp_path, monkeypatch)
    assert exc.line == line_of(tmp_path / "arm.urdf", '<joint name="elbow_flex"')
    assert "joint 'elbow_flex' has no limits" in exc.message


def test_a_missing_mesh_file_where_a_box_would_do(tmp_path, monkeypatch):
    urdf_edited(
        tmp_path,
        '<geometry><box size="0.034 0.050 0.040"/></geometry>',
        '<geometry><mesh filename="package://so101/assets/wrist.stl"/></geometry>',
    )
    (exc,) = errors(write_profile(tmp_path), tmp_path, monkeypatch)
    assert exc.line == line_of(tmp_path / "arm.urdf", "wrist.stl")
    assert "mesh file 'package://so101/assets/wrist.stl' not found" in exc.message
    assert "<box" in exc.message


def test_servo_ids_given_twice(tmp_path, monkeypatch):
    path = write_profile(tmp_path, elbow=2)
    (exc,) = errors(path, tmp_path, monkeypatch)
    assert (exc.file, exc.line) == (str(path), line_of(path, "elbow_flex:"))
    assert "servo id 2 is given twice (shoulder_lift and elbow_flex)" in exc.message


def test_a_baud_rate_the_servos_do_not_run_at(tmp_path, monkeypatch):
    path = write_profile(tmp_path, baud=9600)
    (exc,) = errors(path, tmp_path, monkeypatch)
    assert (exc.line, exc.column) == (line_of(path, "baud:"), 9)
    assert "sts3215 servos (id 1) do not run at 9,600 baud" in exc.message


def test_a_calibration_file_of_other_servos(tmp_path, monkeypatch):
    calibration = tmp_path / "calibration.yml"
    text = resolve("so101_calibration.yml", "profile").read_text()
    calibration.write_text(text.replace("elbow_flex: {id: 3,", "elbow_flex: {id: 7,"))
    path = write_profile(tmp_path, extra="include: calibration.yml\n")
    (exc,) = errors(path, tmp_path, monkeypatch)
    assert (exc.file, exc.line) == (str(calibration), line_of(calibration, "elbow_flex"))
    assert "the calibration is of servo 7, but elbow_flex's servo is 3" in exc.message


@console
def test_armtree_check_places_a_urdf_fault_and_exits_2(tmp_path):
    urdf_edited(tmp_path, '<limit lower="-1.69" upper="1.69" velocity="1.5" effort="10"/>', "")
    write_profile(tmp_path)
    done = subprocess.run(
        [str(BIN / "armtree"), "check", "load_ducky.yaml", "--rig", "mine.yaml"],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 2
    line = line_of(tmp_path / "arm.urdf", '<joint name="elbow_flex"')
    assert f"arm.urdf:{line}:3: joint 'elbow_flex' has no limits" in done.stderr
    assert "Traceback" not in done.stderr


@console
def test_a_servo_that_does_not_answer_is_exit_3_naming_the_port_and_servo(tmp_path):
    # a bus whose gripper servo answers as id 9, not the profile's 6
    emulate = subprocess.Popen(
        [str(BIN / "armtree"), "emulate", "so101", "--set", "gripper={id: 9, model: sts3215}"],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        port = emulate.stdout.readline().strip()
        done = subprocess.run(
            [
                str(BIN / "run-tree"), "load_ducky.yaml", "--rig", "so101.yaml", "--quiet",
                "--set", f"arm.port={port}", "--set", "camera={type: sim}",
            ],
            cwd=tmp_path, capture_output=True, text=True, timeout=120,
        )  # fmt: skip
    finally:
        emulate.send_signal(signal.SIGINT)
        emulate.wait(timeout=30)
    assert done.returncode == 3, done.stdout + done.stderr
    said = done.stdout + done.stderr
    assert f"{port}: the feetech servos did not all come up as configured" in said
    assert "servo 6 (gripper) did not answer a ping" in said
