"""Dobot V1 driver against its firmware emulator over a real pseudo-terminal."""

from __future__ import annotations

import numpy as np
import pytest
from arm_fixtures import ArmSim, connected

from armtree.api.clock import VirtualClock
from armtree.api.emulation import SHARED_KEY
from armtree.api.rig import MotionStatus, RigContext
from armtree.errors import HardwareFault, Unreachable
from armtree.plugins.arms.dobot_v1 import codec
from armtree.plugins.arms.dobot_v1.plugin import dobot_v1_factory


class Sim(ArmSim):
    """A factory-built driver on ``port: sim`` and the run's stepping, as the runtime does it."""

    def __init__(self, **config):
        super().__init__(dobot_v1_factory, {"port": "sim", **config})


@pytest.fixture
def sim():
    yield from connected(Sim())


def test_connect_reads_the_power_up_status(sim):
    assert np.allclose(sim.arm.joints(), sim.arm.model.home, atol=1e-4)
    assert sim.arm.device.startswith("/dev/")
    # the emulator first, then the driver (its homing acts on what the board sent)
    assert sim.context.steppers == [sim.emu.step, sim.arm.step]


def test_move_completes_from_the_arms_reports(sim):
    target = np.array([30.0, 5.0, 45.0])
    while not sim.arm.guard.stable:  # commands wait for a stable run of plausible frames
        sim.tick()
    written = sim.arm.commands_written
    handle = sim.arm.move_joints(target)
    # the status interval is free: the command goes out at once
    assert sim.arm.commands_written == written + 1
    assert handle.status is MotionStatus.RUNNING
    second = sim.arm.move_joints([0.0, 5.0, 45.0])
    assert second.status is MotionStatus.PENDING and sim.arm.commands_written == written + 1
    sim.tick()
    progress = sim.progress_until_done(handle)
    assert handle.status is MotionStatus.DONE
    assert np.all(np.diff(progress) >= -1e-9)
    assert np.allclose(sim.arm.joints(), target, atol=1e-4)
    assert np.allclose(sim.emu.true_joints(), target, atol=1e-4)
    sim.until(second)
    assert sim.emu.dropped == 0


def test_move_to_uses_host_ik_and_reaches_the_point(sim):
    p = sim.arm.model.position([-40.0, 12.0, 52.0])
    handle = sim.arm.move_to(p)
    sim.until(handle)
    assert handle.status is MotionStatus.DONE
    assert np.allclose(sim.arm.pose()[:3, 3], p, atol=1e-2)


def test_suction_on_and_off(sim):
    on = sim.arm.set_suction(True)
    sim.until(on)
    assert on.status is MotionStatus.DONE and sim.emu.tool().suction and sim.arm.tool.suction
    # suction stays on through a move (isGrab in each state-6 frame)
    move = sim.arm.move_joints([10.0, 5.0, 50.0])
    sim.until(move)
    assert sim.emu.tool().suction
    off = sim.arm.set_suction(False)
    sim.until(off)
    assert not sim.emu.tool().suction and not sim.arm.tool.suction


def test_stop_acts_at_once_and_the_arm_brakes(sim):
    handle = sim.arm.move_joints([120.0, 5.0, 45.0])
    sim.tick(4)
    assert handle.status is MotionStatus.RUNNING
    sim.arm.stop()
    assert handle.status is MotionStatus.STOPPED
    sim.tick(40)
    q = sim.arm.joints()
    assert 0.0 < q[0] < 120.0
    before = sim.emu.true_joints()
    sim.tick(10)
    assert np.allclose(sim.emu.true_joints(), before)


def test_duplicate_of_the_last_command_is_not_resent(sim):
    target = [20.0, 5.0, 45.0]
    sim.until(sim.arm.move_joints(target))
    written = sim.arm.commands_written
    again = sim.arm.move_joints(target)
    sim.until(again)
    assert again.status is MotionStatus.DONE
    assert sim.arm.commands_written == written


def test_one_command_per_status_frame_so_none_is_dropped(sim):
    handles = [sim.arm.move_joints([a, 5.0, 45.0]) for a in (5.0, 10.0, 15.0)]
    sim.until(handles[-1])
    assert all(h.status is MotionStatus.DONE for h in handles)
    assert sim.emu.dropped == 0


def test_commands_faster_than_status_frames_are_dropped_by_the_firmware(sim):
    # bypass the driver's pacing: two frames inside one status interval
    first = codec.move_joints([10.0, 5.0, 45.0]).encode()
    second = codec.move_joints([-10.0, 5.0, 45.0]).encode()
    sim.arm.write(first + second)
    sim.tick(60)
    assert sim.emu.dropped == 1
    assert np.allclose(sim.emu.true_joints(), [10.0, 5.0, 45.0], atol=1e-4)


@pytest.mark.parametrize(
    ("target", "match"),
    [
        ([200.0, 5.0, 45.0], "base"),
        ([0.0, 20.0, 40.0], "elbow_opening"),
        ([0.0, float("nan"), 40.0], "not finite"),
        ([0.0, 5.0], "3 joints"),
    ],
)
def test_bad_joint_targets_are_refused_and_nothing_is_sent(sim, target, match):
    sim.tick()
    written = sim.arm.commands_written
    handle = sim.arm.move_joints(target)
    assert handle.status is MotionStatus.FAILED
    assert isinstance(handle.error, Unreachable) and match in str(handle.error)
    sim.tick(3)
    assert sim.arm.commands_written == written


def test_unreachable_point_is_refused(sim):
    handle = sim.arm.move_to([500.0, 0.0, 0.0])
    assert handle.status is MotionStatus.FAILED and isinstance(handle.error, Unreachable)
    handle = sim.arm.move_to([np.nan, 0.0, 0.0])
    assert handle.status is MotionStatus.FAILED and "not finite" in str(handle.error)


def test_link_cut_mid_move_fails_the_handle_and_interrupts(sim):
    handle = sim.arm.move_joints([100.0, 5.0, 45.0])
    sim.tick(5)
    sim.emu.inject("cut")
    assert handle.wait(2.0)
    assert handle.status is MotionStatus.FAILED
    assert isinstance(handle.error, HardwareFault) and handle.error.device == sim.arm.device
    reason, fault = sim.interrupts[0]
    assert sim.arm.device in reason and fault is handle.error
    later = sim.arm.move_joints([0.0, 5.0, 45.0])
    assert later.status is MotionStatus.FAILED and isinstance(later.error, HardwareFault)


def test_missing_port_is_a_clear_hardware_fault():
    context = RigContext(profile=None, clock=VirtualClock())
    arm = dobot_v1_factory({"port": "/dev/ttyUSB-armtree-missing"}, context)
    with pytest.raises(HardwareFault, match="no such serial port") as err:
        arm.connect()
    assert err.value.device == "/dev/ttyUSB-armtree-missing"
    handle = arm.move_joints([0.0, 5.0, 45.0])
    assert handle.status is MotionStatus.FAILED


def test_two_runs_exchange_identical_bytes():
    def run():
        with Sim() as s:
            s.arm.connect()
            s.until(s.arm.move_joints([25.0, 8.0, 48.0]))
            s.until(s.arm.set_suction(True))
            s.until(s.arm.move_to(s.arm.model.position([-30.0, 2.0, 55.0])))
            return [(t, d, b) for t, d, b in s.emu.transcript], s.arm.joints().tolist()

    assert run() == run()


def _ticks_to_finish(sim, handle):
    n = 0
    while not handle.done:
        sim.tick()
        n += 1
    return n


def test_speed_fraction_goes_to_the_firmware_as_state_10(sim):
    fast = _ticks_to_finish(sim, sim.arm.move_joints([60.0, 5.0, 45.0], speed=1.0))
    slow = _ticks_to_finish(sim, sim.arm.move_joints([0.0, 5.0, 45.0], speed=0.25))
    assert sim.emu.speed_ratio == pytest.approx(0.25)
    assert slow > 2 * fast


def test_jump_mode_lifts_crosses_and_lowers(sim):
    model = sim.arm.model
    start = sim.emu.true_joints()
    goal = np.array([40.0, 10.0, 50.0])
    frame = codec.move_joints(goal, mode=codec.MODE_JUMP).encode()
    sim.tick()
    sim.arm.write(frame)
    heights = []
    for _ in range(100):
        sim.tick()
        heights.append(model.position(sim.emu.true_joints())[2])
    z0 = model.position(start)[2]
    assert max(heights) > z0 + 15.0
    assert np.allclose(sim.emu.true_joints(), goal, atol=1e-4)


def test_gripper_angle_is_set_and_kept_through_moves(sim):
    handle = sim.arm.set_gripper(30.0)
    sim.until(handle)
    assert handle.status is MotionStatus.DONE
    assert sim.emu.tool().gripper == pytest.approx(30.0) and sim.arm.tool.gripper == 30.0
    sim.until(sim.arm.move_joints([15.0, 5.0, 45.0]))
    assert sim.emu.tool().gripper == pytest.approx(30.0)
    bad = sim.arm.set_gripper(120.0)
    assert bad.status is MotionStatus.FAILED and isinstance(bad.error, Unreachable)


@pytest.mark.parametrize("firmware", ["original", "open-dobot"])
def test_a_port_path_is_driven_exactly_like_hardware(firmware):
    """An emulator serving on the wall clock (as ``armtree emulate`` does) behind a device path."""
    from armtree.api.clock import WallClock
    from armtree.plugins.arms.dobot_v1.plugin import dobot_v1_emulator

    emu = dobot_v1_emulator({"firmware": firmware}, WallClock())
    path = emu.start()
    context = RigContext(profile=None, clock=WallClock())
    arm = dobot_v1_factory({"port": path, "firmware": firmware}, context)
    try:
        # no emulator stepped: only the original firmware's driver steps (its homing)
        stepped = [] if firmware == "open-dobot" else [arm.step]
        assert context.steppers == stepped and SHARED_KEY not in context.shared
        arm.connect()
        handle = arm.move_joints(np.asarray(arm.joints()) + [3.0, 0.0, 0.0])
        assert handle.wait(10.0)
        assert handle.status is MotionStatus.DONE
    finally:
        arm.close()
        emu.close()


def test_movl_keeps_the_tool_on_a_straight_line(sim):
    model = sim.arm.model
    a = np.array([-20.0, 5.0, 45.0])
    b = np.array([20.0, 12.0, 55.0])
    sim.until(sim.arm.move_joints(a))
    pa, pb = model.position(a), model.position(b)
    sim.tick()
    sim.arm.write(codec.move_joints(b, mode=codec.MODE_MOVL).encode())
    off_line = []
    for _ in range(80):
        sim.tick()
        p = model.position(sim.emu.true_joints())
        s = np.clip((p - pa) @ (pb - pa) / ((pb - pa) @ (pb - pa)), 0, 1)
        off_line.append(np.linalg.norm(p - (pa + s * (pb - pa))))
    assert max(off_line) < 1e-6
    assert np.allclose(sim.emu.true_joints(), b, atol=1e-6)
    # the same target by MOVJ leaves the line (the base turns on an arc)
    sim.until(sim.arm.move_joints(a))
    sim.tick()
    sim.arm.write(codec.move_joints(b, mode=codec.MODE_MOVJ).encode())
    arc = []
    for _ in range(80):
        sim.tick()
        p = model.position(sim.emu.true_joints())
        s = np.clip((p - pa) @ (pb - pa) / ((pb - pa) @ (pb - pa)), 0, 1)
        arc.append(np.linalg.norm(p - (pa + s * (pb - pa))))
    assert max(arc) > 1.0
