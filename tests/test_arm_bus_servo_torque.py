"""Torque goes off on every way a bus-servo arm stops: each fault, and every close.

A driver error, implausible joint readings, a servo gone silent past the retry
budget, an overheated or overloaded servo: each fails the motion, names what
stopped the arm, and leaves every servo limp, before the driver is closed and
after. A faulted link refuses ordinary writes; the torque-off goes out anyway, and
a port that is gone does not make closing wait.
"""

from __future__ import annotations

import time

import pytest
from test_arm_bus_servo_driver import Sim, connected

from armtree.api.rig import MotionStatus

ARMS = ["so101", "koch"]


def on(sim: Sim) -> list[int]:
    """Ids of the emulated servos whose torque is on."""
    return [i for i, t in sim.torque().items() if t]


def moving(sim: Sim):
    """A connected arm with torque on, a motion under way."""
    connected(sim)
    assert on(sim) == [1, 2, 3, 4, 5, 6]
    handle = sim.arm.move_joints(sim.arm.model.home + [30, 0, 0, 0, 0])
    sim.tick(3)
    assert not handle.done
    return handle


def until_fault(sim: Sim, limit: int = 40) -> None:
    for _ in range(limit):
        if sim.arm.fault is not None:
            sim.tick()  # the emulator reads what the driver sent on its way out
            return
        sim.tick()
    raise AssertionError("the driver did not fault")


def closed_limp(sim: Sim) -> None:
    """Closing the faulted driver leaves (and keeps) every torque off."""
    sim.arm.close()
    sim.tick(2)
    assert on(sim) == []


def limp_then_closed(sim: Sim) -> None:
    """Every torque is off at the fault, and stays off when the driver is closed."""
    assert on(sim) == []
    closed_limp(sim)


@pytest.mark.parametrize("name", ARMS)
def test_a_driver_error_turns_every_torque_off(name):
    with Sim(name) as sim:
        handle = moving(sim)

        def bug(packet):
            raise RuntimeError("a protocol bug")

        sim.arm._on_status = bug
        until_fault(sim)
        assert "driver error (RuntimeError: a protocol bug)" in sim.arm.fault.message
        assert handle.status is MotionStatus.FAILED
        limp_then_closed(sim)


@pytest.mark.parametrize("name", ARMS)
def test_implausible_joint_readings_turn_every_torque_off(name):
    with Sim(name) as sim:
        connected(sim)
        assert on(sim) == [1, 2, 3, 4, 5, 6]
        # the arm at rest, a servo's readings jump 150 degrees and stay there (its homing
        # offset changed under it; a knock would not do: the servo's loop takes a knocked
        # horn back): the readings stop making sense
        servo = sim.emu.servo_of(0)
        servo._put("homing_offset", servo.get("homing_offset") + 1707)
        until_fault(sim)
        assert "implausible joint readings" in sim.arm.fault.message
        assert "shoulder_pan" in sim.arm.fault.message
        assert sim.interrupts and sim.interrupts[0][1] is sim.arm.fault
        limp_then_closed(sim)


@pytest.mark.parametrize("name", ARMS)
def test_a_servo_silent_past_the_retry_budget_leaves_the_others_limp(name):
    with Sim(name) as sim:
        handle = moving(sim)
        del sim.emu.servos[2]  # unplugged
        until_fault(sim)
        assert "servo 2 (shoulder_lift) did not answer" in sim.arm.fault.message
        assert sim.arm.lost_status > sim.arm.retries
        assert handle.status is MotionStatus.FAILED
        limp_then_closed(sim)


@pytest.mark.parametrize("name", ARMS)
@pytest.mark.parametrize("trip", ["overheat", "overload"])
def test_a_tripped_servo_fails_the_motion_names_the_servo_and_drops_every_torque(name, trip):
    with Sim(name) as sim:
        handle = moving(sim)
        sim.emu.inject(trip, joint=2)
        until_fault(sim, limit=8)
        assert handle.status is MotionStatus.FAILED
        (reason, fault), *_ = sim.interrupts
        assert reason == f"servo 3 (elbow_flex): {trip}"
        assert f"servo 3 (elbow_flex) reports {trip}: the arm is stopped" in fault.message
        limp_then_closed(sim)


@pytest.mark.parametrize("name", ARMS)
def test_closing_a_faulted_driver_sends_the_torque_off_past_its_refusal(name):
    with Sim(name) as sim:
        connected(sim)
        sim.arm.lose_link("a fault found elsewhere")
        sim.tick()
        assert sim.arm.write(b"\xff") is False  # an ordinary write is refused now
        servo = sim.emu.servos[4]
        servo.write(servo.model.register("torque_enable").address, b"\x01", sim.emu.time)
        assert on(sim) == [4]  # switched on again behind the driver's back
        closed_limp(sim)


@pytest.mark.parametrize("name", ARMS)
def test_a_port_that_is_gone_does_not_hold_up_closing(name):
    with Sim(name) as sim:
        connected(sim)
        sim.emu.inject("cut")  # the adapter pulled out: nothing can be written
        deadline = time.monotonic() + 2.0
        while sim.arm.fault is None and time.monotonic() < deadline:
            time.sleep(0.01)  # the driver's reader finds the hang-up on its own thread
        assert "link lost" in sim.arm.fault.message
        started = time.monotonic()
        sim.arm.close()
        assert time.monotonic() - started < 1.0
