"""``armtree calibrate KIND --rig P``: the trees move the simulated arm, measure, fit and
write the calibration file a profile includes; judged against the simulation's as-built rig."""

from __future__ import annotations

import argparse

import numpy as np
import pytest
import yaml

import armtree
from armtree.plugins.calibration.command import CalibrateCommand

E2H = "sim_dobot_eye_to_hand"
CAMERA_ERROR = "world.as_built={camera: {offset_mm: [3, -2, 4], rotation_deg: [0.4, -0.3, 0.8]}}"


def calibrate(*argv: str) -> int:
    parser = argparse.ArgumentParser()
    CalibrateCommand().configure(parser)
    return CalibrateCommand().run(parser.parse_args(list(argv)))


def test_hand_eye_on_n_poses_finds_the_camera_where_it_really_is(tmp_path, capsys):
    out = tmp_path / "cal.yaml"
    assert (
        calibrate("hand-eye", "--rig", E2H, "--poses", "8", "-o", str(out), "--set", CAMERA_ERROR)
        == 0
    )
    said = capsys.readouterr().out
    assert "hand-eye: pnp: RMS residual" in said and f"wrote {out}" in said
    assert (tmp_path / "cal_hand_eye.png").stat().st_size > 5000
    data = yaml.safe_load(out.read_text())
    record = data["calibration"]["records"]["hand_eye"]
    assert record["method"] == "pnp"
    # no step slipped: the camera looked for it and never found the arm moved
    assert record["missed_steps"]["checks"] >= 3 and record["missed_steps"]["found"] == 0
    error, nominal = camera_errors(E2H, out, np.array([170.0, 20.0, -30.0]))
    assert error < 1.0 < 5.0 < nominal


def camera_errors(rig: str, calibration, probe: np.ndarray) -> tuple[float, float]:
    """How far (mm) the calibrated and the profile's camera poses put ``probe`` from where the
    as-built camera sees it."""
    from armtree.plugins.sim.as_built import AsBuilt
    from armtree.plugins.sim.camera import camera_extrinsics

    profile = armtree.load_profile(rig, [f"include={calibration}", CAMERA_ERROR])
    found = np.array(profile.data["camera"]["extrinsics"])
    nominal = camera_extrinsics(profile.data["camera"])
    true = AsBuilt((3, -2, 4), (0.4, -0.3, 0.8)).camera(nominal)
    point = np.append(probe, 1.0)
    return tuple(
        float(np.linalg.norm((pose @ np.linalg.inv(true) @ point)[:3] - probe))
        for pose in (found, nominal)
    )


def test_hand_eye_homes_and_measures_again_the_poses_after_a_missed_step(tmp_path, capsys):
    # theta1 slips now and then (seeded: the same slips every run), never reported
    out = tmp_path / "cal.yaml"
    slips = "world.faults={missed_steps: {rate_per_s: 0.05, max_amount: 1.0, joints: [1]}}"
    code = calibrate("hand-eye", "--rig", "sim_vicra", "--poses", "6", "-o", str(out),
                     "--set", CAMERA_ERROR, "--set", slips)  # fmt: skip
    assert code == 0
    record = yaml.safe_load(out.read_text())["calibration"]["records"]["hand_eye"]
    assert record["missed_steps"]["found"] >= 1 and record["missed_steps"]["redone"] >= 1
    assert record["residual_rms_mm"] < 0.2  # 0.7 when a slip was kept
    error, _ = camera_errors("sim_vicra", out, np.array([300.0, 0.0, 60.0]))
    assert error < 1.0


def test_hand_eye_is_refused_when_steps_keep_slipping_through_the_homings(tmp_path, capsys):
    # the Dobot V1.0's homing (a board reset) re-references it, but not faster than this
    out = tmp_path / "cal.yaml"
    slips = "world.faults={missed_steps: {rate_per_s: 0.5, max_amount: 1.0, joints: [1]}}"
    code = calibrate("hand-eye", "--rig", E2H, "--poses", "8", "-o", str(out), "--set", slips)
    assert code == 1
    said = capsys.readouterr().err
    assert "was seen somewhere else after each of 5 homings: steps keep slipping" in said
    assert not out.exists()


def test_three_positions_that_do_not_fit_the_workspace_are_refused(tmp_path, capsys):
    code = calibrate("hand-eye", "--rig", E2H, "--method", "three-positions", "--step-mm", "300",
                     "-o", str(tmp_path / "c.yaml"))  # fmt: skip
    assert code == 1
    assert "no three positions 300 mm apart along x then y" in capsys.readouterr().err
    assert not (tmp_path / "c.yaml").exists()


def test_kinematics_finds_the_tool_offset_of_the_real_arm(tmp_path, capsys):
    out = tmp_path / "cal.yaml"
    pencil = "world.as_built={arm: {tool_offset_mm: 48}}"
    assert (
        calibrate(
            "kinematics", "--rig", "sim_dobot", "--poses", "12", "-o", str(out), "--set", pencil
        )
        == 0
    )
    data = yaml.safe_load(out.read_text())
    # the offset trades a little with the joint offsets over a small workspace
    assert data["arm"]["tool_offset_mm"] == pytest.approx(48.0, abs=2.0)
    record = data["calibration"]["records"]["kinematics"]
    assert record["held_out_after_mm"][0] < record["held_out_before_mm"][0] / 3


def test_a_kinematic_fit_that_does_not_help_is_refused(tmp_path, capsys):
    # the simulated arm is as its profile says: a fit can only chase the reading error
    out = tmp_path / "cal.yaml"
    assert calibrate("kinematics", "--rig", "sim_dobot", "--poses", "10", "-o", str(out)) == 1
    assert "makes the held-out error worse" in capsys.readouterr().err and not out.exists()


def test_calibrate_needs_a_rig_or_offline_input(tmp_path):
    with pytest.raises(armtree.ConfigError, match="give --rig PROFILE"):
        calibrate("correction")
    with pytest.raises(armtree.ConfigError, match="hand-eye: give --rig PROFILE"):
        calibrate("hand-eye")


@pytest.mark.parametrize(
    "name",
    [
        "calibrate_camera_offset",
        "calibrate_correction",
        "calibrate_hand_eye",
        "calibrate_kinematics",
    ],
)
def test_py_trees_visitors_see_every_node_of_a_calibration_tree(name):
    import py_trees

    tree = armtree.load_tree(name)
    visitor = py_trees.visitors.SnapshotVisitor()
    visitor.initialise()
    for node in tree.root.iterate():
        node.visit(visitor)  # as BehaviourTree.tick does for each visitor
    assert set(visitor.visited) == {node.id for node in tree.root.iterate()}
