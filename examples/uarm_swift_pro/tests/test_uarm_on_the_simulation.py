"""The uArm Swift Pro in armtree: the plugin loads, its driver talks to the emulated firmware,
and armtree's own pick-and-place tree runs on it, judged by the simulated world."""

from __future__ import annotations

import json
from pathlib import Path

import armtree
import numpy as np
import pytest
from armtree.api.clock import VirtualClock, WallClock
from armtree.cli.commandline import run_tree_main
from armtree.errors import HardwareFault
from armtree.hooks.plugin_checks import deep_problems
from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.runtime.rig_builder import build_rig

from armtree_uarm_swift_pro.driver import SwiftProDriver
from armtree_uarm_swift_pro.emulator import SwiftProEmulator
from armtree_uarm_swift_pro.kinematics import SwiftProModel

ROOT = Path(__file__).resolve().parents[1]
PROFILE = ROOT / "hardware" / "sim_uarm_swift_pro.yaml"


def test_armtree_finds_the_arm_through_the_entry_point_and_it_passes_the_checks():
    component = get_plugin_manager().registry.get("arm", "uarm_swift_pro")
    assert component.distribution == "armtree-uarm-swift-pro"
    assert deep_problems(component) == []


def test_armtrees_pick_and_place_tree_runs_on_the_arm(tmp_path, capsys):
    code = run_tree_main(
        [str(ROOT / "trees" / "uarm_pick_and_place.yaml"), "--quiet", "--record", str(tmp_path)]
    )
    out = capsys.readouterr().out
    assert code == 0 and "result: SUCCESS" in out, out
    score = json.loads((tmp_path / "score.json").read_text())
    ducky = score["objects"]["ducky"]
    assert ducky["on"] == "table" and not ducky["held"]
    assert ducky["position_mm"][:2] == pytest.approx([220, 130], abs=15)  # on the drop-off spot
    assert score["collision_count"] == 0


@pytest.fixture
def rig():
    rig = build_rig(armtree.load_profile(PROFILE), get_plugin_manager(), VirtualClock())
    yield rig
    rig.close()


def firmware_of(rig) -> SwiftProEmulator:
    """The emulated firmware behind ``port: sim`` (a test's view; skills never see it)."""
    (firmware,) = [
        s.__self__
        for s in rig.steppers
        if isinstance(getattr(s, "__self__", None), SwiftProEmulator)
    ]
    return firmware


def run_until_done(rig, handle, seconds=10.0):
    clock = rig.clock
    end = clock.now() + seconds
    while not handle.done and clock.now() < end:
        clock.sleep_until(clock.now() + 0.05)
        rig.step(clock.now())
    return handle


def test_the_driver_refuses_what_the_arm_cannot_reach_before_sending_a_byte(rig):
    firmware = firmware_of(rig)
    sent_before = sum(1 for _, way, _ in firmware.transcript if way == "rx")
    refused = rig.arm.move_to(np.array([0.0, 0.0, 45.0]))
    assert refused.status.value == "failed" and "outside the workspace" in str(refused.error)
    moved = run_until_done(rig, rig.arm.move_to(np.array([250.0, 50.0, 80.0]), speed=0.5))
    assert moved.status.value == "done"
    assert rig.arm.pose()[:3, 3] == pytest.approx([250, 50, 80], abs=0.05)
    commands = [data for _, way, data in list(firmware.transcript) if way == "rx"]
    assert not any(b"X0 Y0 Z45" in c for c in commands)
    assert sum(1 for c in commands if b" G0 " in c) == 1 and len(commands) > sent_before


def test_a_move_with_the_motors_detached_fails_with_the_firmwares_reason(rig):
    firmware = firmware_of(rig)
    firmware.attached = False  # as after M2019 from another program
    failed = run_until_done(rig, rig.arm.move_to(np.array([250.0, 0.0, 100.0])))
    assert failed.status.value == "failed"
    assert "E27 the motors are detached" in str(failed.error)


class MarlinSwiftPro(SwiftProEmulator):
    """A Swift Pro still on firmware 3.x, which calls itself VSwiftPro."""

    def _immediate(self, line, t):
        text = super()._immediate(line, t)
        return text.replace("ok SwiftPro", "ok VSwiftPro")


def test_an_arm_on_firmware_3_is_refused_saying_what_to_do():
    model = SwiftProModel()
    firmware = MarlinSwiftPro(model, WallClock())
    driver = SwiftProDriver(model, firmware.start(), clock=WallClock(), connect_timeout=3.0)
    try:
        with pytest.raises(HardwareFault, match="firmware 3.x .* flash firmware 4.x"):
            driver.connect()
    finally:
        driver.close()
        firmware.close()
