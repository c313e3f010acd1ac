"""``armtree calibrate servos --rig P``: a bus-servo arm's homing offsets and ranges.

On a simulated rig the simulated hand holds the arm at its zero pose and sweeps
every joint; what the command writes is the calibration the emulated kit needs
(its horns where they were mounted), a file the profile includes, after which the
arm reads its true joint angles.
"""

from __future__ import annotations

import argparse

import numpy as np
import pytest
import yaml
from arm_fixtures import ArmSim

import armtree
from armtree.errors import ConfigError
from armtree.plugins.arms.bus_servo.calibration import MIDDLE
from armtree.plugins.arms.bus_servo.plugin import SIM_HORNS
from armtree.plugins.calibration.command import CalibrateCommand


def calibrate(*argv: str) -> int:
    parser = argparse.ArgumentParser()
    command = CalibrateCommand()
    command.configure(parser)
    return command.run(parser.parse_args(["servos", *argv]))


@pytest.mark.parametrize(("arm", "sign"), [("so101", -1), ("koch", 1)])
def test_calibrating_a_fresh_kit_finds_where_its_horns_were_mounted(
    arm, sign, tmp_path, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "kit.yaml").write_text(f"profile: kit\narm: {{type: {arm}, port: sim}}\n")
    assert calibrate("--rig", "kit.yaml", "-o", "mine.yml") == 0
    found = yaml.safe_load((tmp_path / "mine.yml").read_text())["arm"]["calibration"]
    for joint, zero in SIM_HORNS[arm].items():
        # present = actual + sign * offset reads 2048 at the joint's zero
        assert found[joint]["homing_offset"] == -sign * (zero - MIDDLE), joint
    shipped = armtree.load_profile(f"sim_{arm}").component("arm")["calibration"]
    # the shipped rig includes what calibrating its emulated kit gives
    assert {j: c["homing_offset"] for j, c in found.items()} == {
        j: c["homing_offset"] for j, c in shipped.items()
    }
    # ranges: the hand swept each joint from one URDF limit to the other
    pan = found["shoulder_pan"]
    assert pan["range_min"] < MIDDLE < pan["range_max"]

    # the kit with the file included reads its joints where the emulated arm stands
    (tmp_path / "kit.yaml").write_text(
        f"profile: kit\narm: {{type: {arm}, port: sim}}\ninclude: mine.yml\n"
    )
    profile = armtree.load_profile("kit.yaml")
    factory = profile.manager.registry.get("arm", arm).factory
    with ArmSim(factory, profile.component("arm")) as sim:
        sim.arm.connect()
        sim.tick(2)
        np.testing.assert_allclose(sim.arm.joints(), sim.emu.true_joints(), atol=0.1)


def test_an_arm_without_bus_servos_has_nothing_to_calibrate(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match="the dh arm has no bus servos to calibrate"):
        calibrate("--rig", "sim_dh")
    with pytest.raises(ConfigError, match="written as .yaml"):
        calibrate("--rig", "sim_so101", "-o", "mine.txt")
