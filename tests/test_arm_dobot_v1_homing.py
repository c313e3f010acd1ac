"""Homing the Dobot V1.0 (original firmware): the base to 0, then a board reset re-reads the pose.

Driver and emulator over a real pseudo-terminal; the reset is the port closed
and opened again, which the emulator sees as pyserial's input flush.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from arm_fixtures import connected
from hypothesis import given, settings
from hypothesis import strategies as st
from test_arm_dobot_v1_driver import Sim

from armtree.api.rig import MotionStatus
from armtree.errors import HardwareFault, Unreachable
from armtree.plugins.arms.common import check_joint_target
from armtree.plugins.arms.dobot_v1 import opendobot as od
from armtree.plugins.arms.dobot_v1.emulator import BOOT_TIME, accelerometer_pose


@pytest.fixture
def sim():
    yield from connected(Sim())


def half_count_deg(q: np.ndarray) -> np.ndarray:
    """Half an accelerometer count as angles (degrees) at true pose ``q``: the most the
    rear arm's (X reads cos) and the forearm's (X reads sin) reading may be off."""
    h = 0.5 / od.ACCEL_SCALE
    out = []
    for x in (math.cos(math.radians(q[1])), math.sin(math.radians(q[2]))):
        ends = (min(1.0, x + h), max(-1.0, x - h))
        out.append(max(abs(math.asin(e) - math.asin(x)) for e in ends))
    return np.degrees(out) + 1e-9


def home(sim, limit=200):
    handle = sim.arm.home()
    ticks = 0
    while not handle.done:
        assert ticks < limit, f"{handle} did not finish"
        sim.tick()
        ticks += 1
    return handle


def test_connecting_finds_the_board_booted_and_resets_nothing(sim):
    assert sim.emu.port_opens == 1 and sim.emu.reboots == 0
    assert np.allclose(sim.emu.reported_joints(), sim.emu.true_joints())


def test_home_after_missed_steps_makes_the_believed_joints_the_true_ones(sim):
    sim.until(sim.arm.move_joints([25.0, 25.0, 60.0]))
    sim.emu.inject("missed_steps", joint=1, amount=1.8)
    sim.emu.inject("missed_steps", joint=2, amount=-1.6)
    sim.emu.inject("missed_steps", joint=0, amount=0.7)
    assert np.max(np.abs(sim.emu.reported_joints() - sim.emu.true_joints())) >= 1.6
    handle = home(sim)
    assert handle.status is MotionStatus.DONE, handle.error
    assert sim.emu.reboots == 1 and "reset the board" in handle.description
    true, believed = sim.emu.true_joints(), sim.emu.reported_joints()
    # the reset found the arm at the home pose plus its slips; the accelerometers read
    # rear arm and forearm there, within their quantisation, and the arm went home again
    at_reset = np.array([0.7, 10.0 + 1.8, 50.0 - 1.6])
    np.testing.assert_allclose(believed, [0.0, 10.0, 50.0], atol=1e-4)
    assert np.all(np.abs(believed[1:] - true[1:]) <= half_count_deg(at_reset))
    np.testing.assert_allclose(
        (true - believed)[1:], (at_reset - accelerometer_pose(at_reset))[1:], atol=1e-6
    )
    # the base has no sensor: believed 0, and where it truly is did not change
    assert true[0] == pytest.approx(0.7, abs=1e-9)
    # the driver reads the new belief, and later moves land where the world says
    np.testing.assert_allclose(sim.arm.joints(), believed, atol=1e-4)
    target = np.array([-20.0, 15.0, 55.0])
    assert sim.until(sim.arm.move_joints(target)).status is MotionStatus.DONE
    np.testing.assert_allclose(
        sim.emu.true_joints()[1:], target[1:], atol=float(half_count_deg(at_reset).max())
    )


def test_the_board_is_silent_while_it_boots_and_forgets_its_settings(sim):
    assert sim.until(sim.arm.set_suction(True)).status is MotionStatus.DONE
    assert sim.until(sim.arm.set_suction(False)).status is MotionStatus.DONE
    sim.until(sim.arm.move_joints([0.0, 10.0, 50.0], speed=0.5))
    assert sim.emu.speed_ratio == pytest.approx(0.5)
    handle = sim.arm.home()
    frames = []
    while not handle.done:
        sim.tick()
        frames.append((sim.clock.now(), sim.arm.frames_received))
    assert handle.status is MotionStatus.DONE
    silent = [t for (t, n), (_, before) in zip(frames[1:], frames[:-1], strict=True) if n == before]
    assert len(silent) * sim.dt >= BOOT_TIME - sim.dt
    assert sim.emu.speed_ratio == 1.0 and not sim.emu.tool().suction
    # the driver knows the board forgot the speed: a slow move sends it again
    assert sim.until(sim.arm.move_joints([15.0, 10.0, 50.0], speed=0.5)).status is MotionStatus.DONE
    assert sim.emu.speed_ratio == pytest.approx(0.5)


def test_a_board_that_does_not_come_back_is_a_hardware_fault_naming_the_port(sim):
    sim.emu.boot_time = 60.0
    handle = home(sim, limit=400)
    assert handle.status is MotionStatus.FAILED
    assert isinstance(handle.error, HardwareFault) and handle.error.device == sim.arm.device
    assert "did not come back" in str(handle.error)
    reason, fault = sim.interrupts[0]
    assert sim.arm.device in reason and fault is handle.error
    later = sim.arm.move_joints([5.0, 10.0, 50.0])
    assert later.status is MotionStatus.FAILED and isinstance(later.error, HardwareFault)


def test_home_with_the_suction_on_only_moves_and_says_it_is_not_referenced(sim):
    sim.until(sim.arm.move_joints([30.0, 10.0, 50.0]))
    sim.until(sim.arm.set_suction(True))
    handle = home(sim)
    assert handle.status is MotionStatus.DONE and "suction is on" in handle.description
    assert sim.arm.homed is False
    assert sim.emu.reboots == 0 and sim.emu.tool().suction
    np.testing.assert_allclose(sim.arm.joints(), [0.0, 10.0, 50.0], atol=1e-4)
    sim.until(sim.arm.set_suction(False))
    assert home(sim).status is MotionStatus.DONE and sim.arm.homed is True
    assert sim.emu.reboots == 1


def test_a_stop_before_the_reset_ends_the_homing_without_one(sim):
    sim.until(sim.arm.move_joints([60.0, 10.0, 50.0]))
    handle = sim.arm.home()
    sim.tick(3)
    sim.arm.stop()
    assert handle.status is MotionStatus.STOPPED
    sim.tick(80)
    assert sim.emu.reboots == 0 and sim.arm.connected


def test_slips_that_left_the_arm_beyond_its_limits_are_undone_by_the_second_move(sim):
    sim.emu.inject("missed_steps", joint=1, amount=3.5)
    sim.emu.inject("missed_steps", joint=2, amount=-2.8)
    with pytest.raises(Unreachable, match="elbow_opening"):
        check_joint_target(sim.arm.model, sim.emu.true_joints())
    assert home(sim).status is MotionStatus.DONE
    np.testing.assert_allclose(sim.arm.joints(), [0.0, 10.0, 50.0], atol=1e-4)
    check_joint_target(sim.arm.model, sim.emu.true_joints())  # truly back within the limits


def test_homing_on_the_wall_clock_as_on_hardware():
    """The emulator served on its own thread behind a device path, the driver stepped by hand."""
    from armtree.api.clock import WallClock
    from armtree.api.rig import RigContext
    from armtree.plugins.arms.dobot_v1.plugin import dobot_v1_emulator, dobot_v1_factory

    emu = dobot_v1_emulator({}, WallClock())
    emu.boot_time = 0.3  # the real 2 s boot would only make the test slower
    path = emu.start()
    context = RigContext(profile=None, clock=WallClock())
    arm = dobot_v1_factory({"port": path}, context)
    try:
        arm.connect()
        emu.inject("missed_steps", joint=2, amount=1.5)
        handle = arm.home()
        deadline = time.monotonic() + 20.0
        while not handle.done and time.monotonic() < deadline:
            for step in context.steppers:  # the runtime's tick
                step(context.clock.now())
            time.sleep(0.02)
        assert handle.status is MotionStatus.DONE, handle
        assert emu.reboots == 1 and arm.connected
        at_reset = np.array([0.0, 10.0, 51.5])
        assert abs(emu.true_joints()[2] - 50.0) <= half_count_deg(at_reset)[1] + 1e-3
    finally:
        arm.close()
        emu.close()


@settings(max_examples=200, deadline=None)
@given(
    st.floats(-135.0, 135.0),
    st.floats(1.0, 85.0),  # the X channel cannot tell the rear arm's sign: kept positive
    st.floats(-10.0, 85.0),
)
def test_the_accelerometers_read_rear_arm_and_forearm_to_half_a_count(base, rear, fore):
    q = np.array([base, rear, fore])
    read = accelerometer_pose(q)
    assert read[0] == 0.0
    assert np.all(np.abs(read[1:] - q[1:]) <= half_count_deg(q))
