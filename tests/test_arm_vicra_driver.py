"""VICRA driver against the Marlin emulator over a real pseudo-terminal."""

from __future__ import annotations

import numpy as np
import pytest
import serial
from arm_fixtures import ArmSim, served

from armtree.api.clock import VirtualClock, WallClock
from armtree.api.rig import MotionStatus, RigContext
from armtree.errors import HardwareFault, Unreachable
from armtree.plugins.arms.dobot_v1.plugin import dobot_v1_factory
from armtree.plugins.arms.vicra import gcode as G
from armtree.plugins.arms.vicra.plugin import vicra_factory


class Sim(ArmSim):
    """A factory-built VICRA on ``port: sim`` stepped as the runtime does it."""

    limit = 1000

    def __init__(self, **config):
        super().__init__(vicra_factory, {"port": "sim", **config})

    def until_homed(self, limit=1000):
        for _ in range(limit):
            if self.arm.homed and (self.arm.settled or not self.arm.home_on_connect):
                return
            self.tick()
        raise AssertionError("the arm did not home")

    def lines_received(self):
        text = self.received_bytes().decode()
        return [G.parse_host_line(x).command for x in text.splitlines() if x]


@pytest.fixture
def sim():
    with Sim() as s:
        s.arm.connect()
        s.until_homed()
        yield s


def test_connect_reads_the_banner_and_homes_on_the_end_stops():
    with Sim() as s:
        s.arm.connect()
        assert s.arm.banner[0] == "start" and any("Marlin" in x for x in s.arm.banner)
        # until the start-up homing ends, the driver reports where it will end
        np.testing.assert_allclose(s.arm.joints(), s.arm.model.park, atol=1e-9)
        s.until_homed()
        assert s.arm.endstops == {"x_min": True, "y_max": True, "z_max": True}
        np.testing.assert_allclose(s.emu.true_joints()[:3], s.emu.reported_joints()[:3], atol=1e-9)
        np.testing.assert_allclose(s.emu.true_joints(), s.arm.model.park, atol=0.02)
        assert s.lines_received()[:2] == ["M110 N0", "G90"]
        assert "G28" in s.lines_received()


def test_moves_are_refused_until_homed():
    with Sim(home_on_connect=False) as s:
        s.arm.connect()
        # power-up: the firmware counts from zero while the arm is elsewhere
        np.testing.assert_allclose(s.emu.reported_joints()[:3], 0.0, atol=1e-9)
        assert not np.allclose(s.emu.true_joints()[:3], 0.0)
        handle = s.arm.move_joints([100.0, 0.0, 90.0, 0.0])
        assert handle.status is MotionStatus.FAILED and "not homed" in str(handle.error)
        s.tick(3)
        assert not any(c.startswith("G1") for c in s.lines_received())
        home = s.arm.home()
        s.until(home)
        assert home.status is MotionStatus.DONE and s.arm.homed
        np.testing.assert_allclose(s.emu.true_joints(), s.arm.model.home, atol=0.02)


def test_the_firmware_itself_refuses_unhomed_moves():
    with Sim(home_on_connect=False) as s:
        s.arm.connect()
        s.arm.close()
        with serial.Serial(s.arm.device, 115200, timeout=0.05) as port:
            port.write(b"M110 N0\nN1 G1 X10 Y20 F3000*78\n")
            s.tick()
            assert port.read_until(b"ok\n") == b"ok\n"
            assert port.read(256) == b"echo:Home XYZ First\nok\n"


def test_move_to_takes_the_nearer_elbow_and_completes_from_m114(sim):
    target = np.array([400.0, 100.0, 50.0])
    right, left = sim.arm.model.ik_all(target)
    handle = sim.arm.move_to(target)
    progress = sim.progress_until_done(handle)
    assert handle.status is MotionStatus.DONE
    assert np.all(np.diff(progress) >= -1e-9)
    q = sim.emu.true_joints()
    assert np.allclose(q, right, atol=0.02) or np.allclose(q, left, atol=0.02)
    start = sim.arm.model.park  # the start-up homing ends there
    nearer = min((right, left), key=lambda s: np.linalg.norm(s - start))
    np.testing.assert_allclose(q, nearer, atol=0.02)
    np.testing.assert_allclose(sim.arm.pose()[:3, 3], target, atol=0.1)


def test_wrist_servo_turns_after_m400(sim):
    handle = sim.until(sim.arm.move_joints([150.0, 10.0, 60.0, 30.0]))
    assert handle.status is MotionStatus.DONE
    lines = sim.lines_received()
    g1 = max(i for i, c in enumerate(lines) if c.startswith("G1"))
    assert lines[g1 + 1 :][:2] == ["M400", "M280 P0 S120.0"]
    np.testing.assert_allclose(sim.emu.true_joints(), [150.0, 10.0, 60.0, 30.0], atol=0.02)


def test_gripper_and_pump():
    with Sim(tool="suction") as s:
        s.arm.connect()
        s.until_homed()
        on = s.until(s.arm.set_suction(True))
        assert on.status is MotionStatus.DONE and s.emu.tool().suction and s.arm.tool.suction
        grip = s.until(s.arm.set_gripper(20.0))
        assert grip.status is MotionStatus.DONE and s.emu.tool().gripper == 20.0
        assert "M106 S255" in s.lines_received() and "M280 P1 S20" in s.lines_received()
        assert s.arm.set_gripper(200.0).status is MotionStatus.FAILED


def test_gripper_tool_stands_in_for_suction(sim):
    sim.until(sim.arm.set_suction(True))
    assert sim.emu.tool().gripper == 0.0 and not sim.emu.tool().suction
    sim.until(sim.arm.set_suction(False))
    assert sim.emu.tool().gripper == 90.0


def test_stop_sends_m410_and_the_arm_stops_at_once(sim):
    handle = sim.arm.move_joints([0.0, 100.0, 100.0, 0.0])
    sim.tick(10)
    assert handle.status is MotionStatus.RUNNING
    sim.arm.stop()
    assert handle.status is MotionStatus.STOPPED
    sim.tick()
    stopped = sim.emu.true_joints()
    sim.tick(20)
    np.testing.assert_allclose(sim.emu.true_joints(), stopped, atol=1e-9)
    assert stopped[1] < 100.0 and "M410" in sim.lines_received()
    # the arm takes commands again
    again = sim.until(sim.arm.move_joints([300.0, 0.0, 90.0, 0.0]))
    assert again.status is MotionStatus.DONE


def test_bad_checksum_gets_error_and_resend_and_the_driver_recovers(sim):
    original = sim.arm._transmit
    corrupted = []

    def corrupt_once(line):
        if line.command.startswith("G1") and not corrupted:
            corrupted.append(line.number)
            line.sent_at = sim.arm.now
            sim.arm.write(f"N{line.number} {line.command}*0\n".encode())
            return
        original(line)

    sim.arm._transmit = corrupt_once
    handle = sim.until(sim.arm.move_joints([250.0, 20.0, 70.0, 0.0]))
    assert handle.status is MotionStatus.DONE and corrupted
    replies = b"".join(b for _, d, b in sim.emu.transcript if d == "tx").decode()
    assert f"Error:checksum mismatch, Last Line: {corrupted[0] - 1}" in replies
    assert f"Resend: {corrupted[0]}" in replies
    np.testing.assert_allclose(sim.emu.true_joints()[:3], [250.0, 20.0, 70.0], atol=0.02)


def test_line_number_errors_from_the_firmware(sim):
    sim.arm.close()
    with serial.Serial(sim.arm.device, 115200, timeout=0.05) as port:
        last = sim.emu.last_n
        port.write(f"{G.numbered(last + 5, 'M114')}\n".encode())
        sim.tick()
        text = port.read(512).decode()
        assert text == (
            f"Error:Line Number is not Last Line Number+1, Last Line: {last}\n"
            f"Resend: {last + 1}\nok\n"
        )
        port.write(f"N{last + 1} M114\n".encode())
        sim.tick()
        assert "No Checksum with line number" in port.read(512).decode()
        port.write(f"{G.numbered(last + 1, 'M119')}\n".encode())
        sim.tick()
        report = port.read(512).decode().splitlines()
        assert report[0] == "Reporting endstop status" and report[-1] == "ok"
        # homed: the arm rests on every switch
        assert {G.parse_endstop(x) for x in report[1:-1]} == {
            ("x_min", True),
            ("y_max", True),
            ("z_max", True),
        }


def test_m112_halts_the_board_and_is_a_hardware_fault(sim):
    sim.arm.emergency_stop()
    sim.tick(2)
    assert sim.emu.killed
    assert isinstance(sim.arm.fault, HardwareFault) and "halted" in str(sim.arm.fault)
    assert sim.interrupts


@pytest.mark.parametrize(
    ("target", "match"),
    [
        ([700.0, 0.0, 0.0, 0.0], "z"),
        ([100.0, 170.0, 0.0, 0.0], "theta1"),
        ([100.0, 0.0, np.nan, 0.0], "not finite"),
    ],
)
def test_bad_targets_are_refused_and_nothing_is_sent(sim, target, match):
    before = sim.lines_received()
    handle = sim.arm.move_joints(target)
    assert handle.status is MotionStatus.FAILED
    assert isinstance(handle.error, Unreachable) and match in str(handle.error)
    sim.tick(2)
    assert [c for c in sim.lines_received() if c.startswith("G1")] == [
        c for c in before if c.startswith("G1")
    ]
    assert sim.arm.move_to([700.0, 0.0, 0.0]).status is MotionStatus.FAILED


def test_missed_steps_are_undone_by_homing(sim):
    sim.until(sim.arm.move_joints([200.0, 0.0, 90.0, 0.0]))
    sim.emu.inject("missed_steps", joint=1, amount=3.0)
    assert sim.emu.true_joints()[1] == pytest.approx(3.0, abs=0.02)
    assert sim.arm.joints()[1] == pytest.approx(0.0, abs=0.02)
    sim.until(sim.arm.home())
    np.testing.assert_allclose(sim.emu.true_joints(), sim.arm.model.home, atol=0.02)


def test_a_step_missed_while_homing_does_not_move_where_the_switch_stops_the_axis(sim):
    sim.until(sim.arm.move_joints([200.0, 0.0, 90.0, 0.0]))
    handle = sim.arm.home()
    for _ in range(200):  # well into the drive toward the end stops
        sim.tick()
        if sim.emu.joints.moving(sim.emu.time):
            break
    assert sim.emu.joints.moving(sim.emu.time)
    sim.emu.inject("missed_steps", joint=1, amount=2.0)
    sim.until(handle)
    assert sim.arm.homed  # M119: the switches closed
    np.testing.assert_allclose(sim.emu.true_joints(), sim.arm.model.home, atol=0.02)


def test_link_cut_fails_the_move_and_interrupts(sim):
    handle = sim.arm.move_joints([0.0, 100.0, 100.0, 0.0])
    sim.tick(3)
    sim.emu.inject("cut")
    assert handle.wait(3.0)
    assert handle.status is MotionStatus.FAILED and isinstance(handle.error, HardwareFault)
    assert sim.interrupts


def test_a_dobot_is_recognised_as_the_wrong_protocol():
    # a Dobot V1.0 streaming its binary status frames where Marlin was expected
    with served(dobot_v1_factory) as path:
        arm = vicra_factory({"port": path}, RigContext(profile=None, clock=WallClock()))
        arm.connect_timeout = 1.0
        with pytest.raises(HardwareFault, match="wrong protocol.*Dobot") as err:
            arm.connect()
        assert err.value.device == path


def test_missing_port():
    arm = vicra_factory({"port": "/dev/ttyACM-armtree-missing"}, RigContext(None, VirtualClock()))
    with pytest.raises(HardwareFault, match="no such serial port"):
        arm.connect()


def test_two_runs_exchange_identical_bytes():
    def run():
        with Sim() as s:
            s.arm.connect()
            s.until_homed()
            s.until(s.arm.move_to([400.0, 100.0, 50.0]))
            s.until(s.arm.move_joints([100.0, 10.0, 20.0, 30.0]))
            return list(s.emu.transcript)

    assert run() == run()


def test_a_lost_ok_is_recovered_by_sending_the_line_again(sim):
    sim.tick()
    handle = sim.arm.move_joints([250.0, -20.0, 120.0, 0.0])
    sim.emu.inject("corrupt", count=2)  # the G1's "ok" arrives unreadable
    sim.until(handle)
    assert handle.status is MotionStatus.DONE and not sim.interrupts
    replies = b"".join(b for _, d, b in sim.emu.transcript if d == "tx").decode("ascii", "replace")
    assert "Error:Line Number is not Last Line Number+1" in replies
    g1 = [c for c in sim.lines_received() if c.startswith("G1")]
    assert len(g1) == 2 and g1[0] == g1[1]  # sent twice, run once
    np.testing.assert_allclose(sim.emu.true_joints()[:3], [250.0, -20.0, 120.0], atol=0.02)
