"""``armtree jog``: the terminal UI driven through textual's pilot on the simulated Dobot.

Keys jog a joint and a Cartesian axis by the chosen step, switch the suction,
record the pose as a named place into the profile (every other line of the file,
comments included, kept) and go home; the arm (the firmware emulator behind its
pty, on the wall clock) really moves there.
"""

import asyncio
import time

import numpy as np
import pytest

from armtree.api.clock import WallClock
from armtree.config.resolve import resolve
from armtree.errors import ConfigError
from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.loader.profile import load_profile
from armtree.plugins.arms.jog import Jogger, build_app, places_file
from armtree.runtime.rig_builder import build_rig

pytest.importorskip("textual", reason="textual draws the jog UI")


async def until(pilot, condition, timeout=15.0):
    deadline = time.monotonic() + timeout
    while not condition():
        app = pilot.app
        assert time.monotonic() < deadline, f"timed out: {app.jogger.message}"
        await pilot.pause(0.05)


@pytest.fixture
def rig_file(tmp_path):
    text = resolve("sim_dobot", "profile").read_text()
    # The planner is not used by jog; a direct one builds at once.
    text = text.replace(
        "planner: {type: prm, milestones: 1000, neighbours: 5}", "planner: {type: direct}"
    )
    # The emulator shares this process (and, in CI, two busy cores) with the UI: a long
    # link timeout keeps a slow scheduler from passing for a lost link.
    text = text.replace("  baud: 9600\n", "  baud: 9600\n  link_timeout: 5\n")
    path = tmp_path / "rig.yaml"
    path.write_text(text)
    return path


def test_jog_keys_move_the_arm_and_record_a_place_keeping_the_file(rig_file):
    before = rig_file.read_text()
    rig = build_rig(load_profile(rig_file), get_plugin_manager(), WallClock())
    app = build_app(rig, rig_file)
    arm = rig.arm

    async def drive():
        async with app.run_test(size=(120, 40)) as pilot:
            await until(pilot, lambda: app.query_one("#joints").row_count == 3)
            q0 = arm.joints().copy()
            await pilot.press("up")  # joint 1 by the default 10 degree step
            await until(pilot, lambda: abs(arm.joints()[0] - (q0[0] + 10)) < 0.05)
            await until(pilot, lambda: not app.jogger.busy())
            await pilot.press("left_square_bracket")  # step 5
            await pilot.press("m")  # Cartesian
            z0 = arm.pose()[2, 3]
            await pilot.press("pageup")
            await until(pilot, lambda: abs(arm.pose()[2, 3] - (z0 + 5)) < 0.1)
            await until(pilot, lambda: not app.jogger.busy())
            await pilot.press("t")
            await until(pilot, lambda: arm.tool.suction)
            await until(pilot, lambda: not app.jogger.busy())
            xyz = np.round(arm.pose()[:3, 3], 1)
            await pilot.press("r")
            await pilot.press(*"spot_a", "enter")
            await until(pilot, lambda: "spot_a" in app.jogger.recorded)
            await pilot.press("h")
            await until(pilot, lambda: np.allclose(arm.joints(), arm.model.home, atol=0.05))
            status = str(app.query_one("#status").render())
            await pilot.press("q")
            return xyz, status

    try:
        xyz, status = asyncio.run(drive())
    finally:
        rig.close()
    assert "mode cartesian" in status and "step 5" in status
    after = rig_file.read_text()
    added = [line for line in after.splitlines() if line not in before.splitlines()]
    assert added == [f"  spot_a: [{xyz[0]:.1f}, {xyz[1]:.1f}, {xyz[2]:.1f}]"]
    assert [line for line in before.splitlines() if line not in after.splitlines()] == []
    assert load_profile(rig_file).data["places"]["spot_a"] == pytest.approx(xyz.tolist(), abs=0.06)


def test_jogging_past_a_joint_limit_is_refused_with_the_reason(rig_file):
    rig = build_rig(load_profile(rig_file), get_plugin_manager(), WallClock())
    try:
        jogger = Jogger(rig, step_index=4)
        for _ in range(20):  # 20 degree steps: the base stops at its limit
            handle = jogger.jog_joint(-1)
            handle.wait(10)
            jogger.poll()
            if handle.error is not None:
                break
        assert handle.error is not None and "base = -140.000 deg is outside" in jogger.message
        assert rig.arm.joints()[0] >= rig.arm.model.joints[0].lower - 1e-6
    finally:
        rig.close()


def test_places_of_a_shipped_profile_go_only_where_the_user_says(tmp_path):
    profile = load_profile("sim_dobot")
    with pytest.raises(ConfigError, match="--save"):
        places_file(profile, None)
    copy = places_file(profile, str(tmp_path / "mine.yaml"))
    assert copy.read_text() == resolve("sim_dobot", "profile").read_text()


@pytest.mark.parametrize("rig_name", ["sim_so101", "sim_koch"])
def test_jogging_a_bus_servo_arm_shows_counts_and_degrees_and_records_places(rig_name, tmp_path):
    from armtree.plugins.arms.jog import limits_text

    profile = load_profile(rig_name)
    target = places_file(profile, str(tmp_path / "mine.yaml"))
    rig = build_rig(profile, get_plugin_manager(), WallClock())
    try:
        jogger = Jogger(rig, step_index=3)  # 10 degrees
        q0 = rig.arm.joints().copy()
        handle = jogger.jog_joint(1)
        assert handle.wait(15) and handle.error is None, jogger.message
        assert rig.arm.joints()[0] == pytest.approx(q0[0] + 10.0, abs=0.1)
        name, position, limits = limits_text(rig)[0]
        assert name == "shoulder_pan" and position.split()[1] == "deg"
        assert float(position.split()[0]) == pytest.approx(q0[0] + 10.0, abs=0.1)
        counts = int(position.split("(")[1].split()[0])
        cal = profile.component("arm")["calibration"]["shoulder_pan"]
        assert counts == pytest.approx(2048 + (q0[0] + 10.0) * 4096 / 360, abs=1.5)
        assert cal["range_min"] < counts < cal["range_max"]
        jogger.toggle_mode()
        z0 = rig.arm.pose()[2, 3]
        handle = jogger.jog_axis("z", -1)
        assert handle.wait(15) and handle.error is None, jogger.message
        assert rig.arm.pose()[2, 3] == pytest.approx(z0 - 10.0, abs=0.3)
        xyz = jogger.record("spot_b", target)
    finally:
        rig.close()
    assert f"  spot_b: [{xyz[0]:.1f}, {xyz[1]:.1f}, {xyz[2]:.1f}]" in target.read_text()
