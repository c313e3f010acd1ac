"""Dobot Magician driver against its firmware emulator over a real pseudo-terminal."""

from __future__ import annotations

import numpy as np
import pytest
from arm_fixtures import ArmSim, connected, served

from armtree.api.clock import VirtualClock, WallClock
from armtree.api.rig import MotionStatus, RigContext
from armtree.errors import HardwareFault, Unreachable
from armtree.plugins.arms.dobot_magician import protocol as P
from armtree.plugins.arms.dobot_magician.plugin import magician_factory
from armtree.plugins.arms.vicra.plugin import vicra_factory


class Sim(ArmSim):
    """A factory-built Magician on ``port: sim`` stepped as the runtime does it."""

    def __init__(self, **config):
        super().__init__(magician_factory, {"port": "sim", **config})

    def received(self) -> int:
        return len(self.received_bytes())


@pytest.fixture
def sim():
    yield from connected(Sim())


def test_connect_reads_the_pose(sim):
    assert np.allclose(sim.arm.joints(), sim.arm.model.home, atol=1e-4)
    assert sim.context.steppers == [sim.emu.step]
    assert sim.emu.running  # the driver restarted the queue


def test_move_done_when_the_queue_index_reaches_it(sim):
    target = np.array([20.0, 30.0, 40.0, 10.0])
    handle = sim.arm.move_joints(target)
    sim.tick()
    assert handle.status is MotionStatus.RUNNING
    progress = sim.progress_until_done(handle)
    assert handle.status is MotionStatus.DONE
    assert np.all(np.diff(progress) >= -1e-9)
    assert np.allclose(sim.arm.joints(), target, atol=1e-3)
    assert np.allclose(sim.emu.true_joints(), target, atol=1e-3)
    assert sim.emu.current_index >= 1


@pytest.mark.parametrize("mode", list(P.PTPMode))
def test_every_ptp_mode_reaches_its_target(sim, mode):
    model = sim.arm.model
    q_goal = np.array([15.0, 35.0, 30.0, 5.0])
    q_now = sim.arm.joints()
    if mode in (P.PTPMode.JUMP_ANGLE, P.PTPMode.MOVJ_ANGLE, P.PTPMode.MOVL_ANGLE):
        target = q_goal
    elif mode is P.PTPMode.MOVJ_INC:
        target = q_goal - q_now
    elif mode in (P.PTPMode.MOVL_INC, P.PTPMode.MOVJ_XYZ_INC):
        target = model.pose_xyzr(q_goal) - model.pose_xyzr(q_now)
    else:
        target = model.pose_xyzr(q_goal)
    handle = sim.until(sim.arm.move_ptp(mode, target))
    assert handle.status is MotionStatus.DONE, handle.error
    assert np.allclose(sim.emu.true_joints(), q_goal, atol=1e-3)
    assert sim.emu.alarms == []


def test_movl_runs_a_straight_line(sim):
    start = sim.arm.model.position(sim.arm.joints())
    goal = start + np.array([0.0, 60.0, -30.0])
    handle = sim.arm.move_linear(goal)
    path = []
    while not handle.done:
        sim.tick(dt=0.02)
        path.append(sim.arm.model.position(sim.emu.true_joints()))
    path = np.array(path)
    direction = (goal - start) / np.linalg.norm(goal - start)
    off_line = np.linalg.norm(np.cross(path - start, direction), axis=1)
    assert off_line.max() < 0.01
    assert np.allclose(path[-1], goal, atol=1e-3)


def test_jump_lifts_above_both_ends(sim):
    model = sim.arm.model
    a, b = model.pose_xyzr(sim.arm.joints()), model.pose_xyzr(np.array([-20.0, 40.0, 35.0, 0.0]))
    handle = sim.arm.move_ptp(P.PTPMode.JUMP_XYZ, b)
    top = -np.inf
    while not handle.done:
        sim.tick(dt=0.02)
        top = max(top, model.position(sim.emu.true_joints())[2])
    assert top >= max(a[2], b[2]) + sim.emu.planner.jump_height - 1e-6


def test_suction_and_gripper_execute_in_queue_order(sim):
    move = sim.arm.move_joints([10.0, 40.0, 40.0, 0.0])
    suck = sim.arm.set_suction(True)
    sim.tick(2)
    assert not sim.emu.tool().suction  # still moving: the cup waits its turn in the queue
    sim.until(suck)
    assert move.status is MotionStatus.DONE and suck.status is MotionStatus.DONE
    assert sim.emu.tool().suction and sim.arm.tool.suction
    grip = sim.until(sim.arm.set_gripper(0.0))
    assert grip.status is MotionStatus.DONE and sim.emu.tool().gripper == 0.0


def test_wait_and_home_commands(sim):
    sim.until(sim.arm.move_joints([30.0, 20.0, 20.0, 0.0]))
    t0 = sim.clock.now()
    sim.until(sim.arm.wait(500))
    assert sim.clock.now() - t0 >= 0.5
    sim.until(sim.arm.home())
    assert np.allclose(sim.emu.true_joints(), sim.arm.model.home, atol=1e-3)


def test_stop_acts_at_once_and_the_arm_brakes(sim):
    handle = sim.arm.move_joints([80.0, 45.0, 45.0, 0.0])
    follow = sim.arm.set_suction(True)
    sim.tick(4)
    assert handle.status is MotionStatus.RUNNING
    sim.arm.stop()
    assert handle.status is MotionStatus.STOPPED and follow.status is MotionStatus.STOPPED
    sim.tick(60)
    q = sim.emu.true_joints()
    assert 0.0 < q[0] < 80.0
    assert not sim.emu.tool().suction  # the queued suction was cleared, not executed
    # the queue runs again afterwards
    assert sim.until(sim.arm.move_joints([0.0, 45.0, 45.0, 0.0])).status is MotionStatus.DONE


def test_duplicate_of_the_last_command_is_not_resent(sim):
    first = sim.arm.move_joints([25.0, 40.0, 40.0, 0.0])
    sim.tick()
    sent = sim.received()
    again = sim.arm.move_joints([25.0, 40.0, 40.0, 0.0])
    assert again is first
    sim.tick()
    ptp_frames = [b for _, d, b in sim.emu.transcript if d == "rx" and b[3:4] == bytes([84])]
    assert len(ptp_frames) == 1 and sim.received() >= sent


@pytest.mark.parametrize(
    ("target", "match"),
    [
        ([120.0, 40.0, 40.0, 0.0], "j1"),
        ([0.0, 95.0, 40.0, 0.0], "j2"),
        ([0.0, 40.0, np.nan, 0.0], "not finite"),
        ([0.0, 40.0, 40.0], "four"),
    ],
)
def test_bad_joint_targets_are_refused_and_nothing_is_sent(sim, target, match):
    sim.tick()
    before = sim.received()
    handle = sim.arm.move_joints(target)
    assert handle.status is MotionStatus.FAILED
    assert isinstance(handle.error, Unreachable) and match in str(handle.error)
    frames = [b for _, d, b in sim.emu.transcript if d == "rx" and P.Cmd.PTP in b[3:4]]
    sim.tick(2)
    assert [b for _, d, b in sim.emu.transcript if d == "rx" and P.Cmd.PTP in b[3:4]] == frames
    assert sim.received() >= before


def test_unreachable_point_is_refused(sim):
    for target in ([1000.0, 0.0, 0.0], [np.nan, 0.0, 0.0]):
        handle = sim.arm.move_to(target)
        assert handle.status is MotionStatus.FAILED and isinstance(handle.error, Unreachable)


def test_wrong_checksum_gets_no_reply_as_on_the_arm(sim):
    sim.tick()
    sim.arm.close()
    bad = bytearray(P.encode(P.Cmd.GET_POSE, 0))
    bad[-1] ^= 0xFF
    replies_before = [b for _, d, b in sim.emu.transcript if d == "tx"]
    import serial

    with serial.Serial(sim.arm.device, 115200, timeout=0.05) as port:
        port.write(bytes(bad))
        sim.tick()
        assert port.read(64) == b""
        port.write(P.encode(P.Cmd.GET_POSE, 0))
        sim.tick()
        reply = P.FrameParser().feed(port.read(64))
    assert [f.id for f in reply] == [P.Cmd.GET_POSE] and len(reply[0].params) == 32
    assert sim.emu.parser.bad_checksums == 1
    assert len([b for _, d, b in sim.emu.transcript if d == "tx"]) == len(replies_before) + 1


def test_link_cut_mid_move_fails_the_handle_and_interrupts(sim):
    handle = sim.arm.move_joints([60.0, 40.0, 40.0, 0.0])
    sim.tick(3)
    sim.emu.inject("cut")
    assert handle.wait(2.0)
    assert handle.status is MotionStatus.FAILED and isinstance(handle.error, HardwareFault)
    assert sim.interrupts and sim.arm.device in sim.interrupts[0][0]


def test_corrupted_replies_are_survived(sim):
    sim.emu.inject("corrupt", count=3)
    handle = sim.until(sim.arm.move_joints([-15.0, 35.0, 35.0, 0.0]))
    assert handle.status is MotionStatus.DONE
    assert not sim.interrupts


def test_missing_port_is_a_clear_hardware_fault():
    context = RigContext(profile=None, clock=VirtualClock())
    arm = magician_factory({"port": "/dev/ttyUSB-armtree-missing"}, context)
    with pytest.raises(HardwareFault, match="no such serial port") as err:
        arm.connect()
    assert err.value.device == "/dev/ttyUSB-armtree-missing"
    assert arm.move_joints([0.0, 45.0, 45.0, 0.0]).status is MotionStatus.FAILED


def test_a_marlin_board_is_recognised_as_the_wrong_protocol():
    # the VICRA's Marlin emulator (serving itself on the wall clock) where a Magician was expected
    with served(vicra_factory) as path:
        arm = magician_factory({"port": path}, RigContext(profile=None, clock=WallClock()))
        arm.connect_timeout = 1.0
        with pytest.raises(HardwareFault, match="wrong protocol.*Marlin") as err:
            arm.connect()
        assert err.value.device == path


def test_two_runs_exchange_identical_bytes():
    def run():
        with Sim() as s:
            s.arm.connect()
            s.until(s.arm.move_to([220.0, 30.0, 20.0]))
            s.until(s.arm.set_suction(True))
            s.until(s.arm.move_linear([200.0, -40.0, 40.0]))
            return [(t, d, b) for t, d, b in s.emu.transcript], s.arm.joints().tolist()

    assert run() == run()


def test_ptp_parameters_are_queued_and_applied(sim):
    handle = sim.until(
        sim.arm.set_ptp_params(
            joint_velocity=50.0, joint_accel=100.0, xyz_velocity=80.0, jump_height=35.0
        )
    )
    assert handle.status is MotionStatus.DONE
    assert sim.emu.planner.joint_speed.tolist() == [50.0] * 4
    assert sim.emu.planner.xyz_speed == 80.0 and sim.emu.planner.jump_height == 35.0
    # slower joints: a 40 degree base turn now takes at least 40 / 50 s
    t0 = sim.clock.now()
    sim.until(sim.arm.move_joints([40.0, 45.0, 45.0, 0.0]))
    assert sim.clock.now() - t0 >= 0.8
    assert sim.arm.left_space is not None and 0 <= sim.arm.left_space <= 32
    with pytest.raises(ValueError):
        sim.arm.set_ptp_params(joint_velocity=-1.0)


def test_lost_reply_resends_absolute_moves_but_not_incremental_ones(sim):
    sim.until(sim.arm.move_joints([0.0, 45.0, 45.0, 0.0]))  # speed ratio now set
    reply = len(P.encode(P.Cmd.PTP, 3, P.index_params(1)))
    # the reply to an absolute move is lost: the driver resends it (running it twice is harmless)
    sim.emu.inject("drop", count=reply)
    handle = sim.until(sim.arm.move_joints([10.0, 40.0, 40.0, 0.0]))
    assert handle.status is MotionStatus.DONE
    np.testing.assert_allclose(sim.emu.true_joints(), [10.0, 40.0, 40.0, 0.0], atol=1e-3)
    # the reply to an incremental move is lost: not sent twice, the move fails instead
    sim.emu.inject("drop", count=reply)
    inc = sim.until(sim.arm.move_ptp(P.PTPMode.MOVJ_INC, [5.0, 0.0, 0.0, 0.0]))
    assert inc.status is MotionStatus.FAILED and "not resent" in str(inc.error)
    sim.tick(40)
    ptp = [b for _, d, b in sim.emu.transcript if d == "rx" and b[3:4] == bytes([84])]
    assert [b[5] for b in ptp[-3:]] == [P.PTPMode.MOVJ_ANGLE] * 2 + [P.PTPMode.MOVJ_INC]
    # the arm did run it once
    np.testing.assert_allclose(sim.emu.true_joints(), [15.0, 40.0, 40.0, 0.0], atol=1e-3)
    assert not sim.interrupts


def test_a_straight_line_through_the_unreachable_middle_is_refused(sim):
    model = sim.arm.model
    a = model.pose_xyzr(np.array([-80.0, 45.0, 30.0, 0.0]))
    b = model.pose_xyzr(np.array([80.0, 45.0, 30.0, 0.0]))
    sim.until(sim.arm.move_ptp(P.PTPMode.MOVJ_XYZ, a))
    sent = [x for _, d, x in sim.emu.transcript if d == "rx" and x[3:4] == bytes([84])]
    # both ends reachable, but the chord passes too close to the base
    line = sim.arm.move_ptp(P.PTPMode.MOVL_XYZ, b)
    assert line.status is MotionStatus.FAILED and "leaves the workspace" in str(line.error)
    sim.tick(2)
    assert [x for _, d, x in sim.emu.transcript if d == "rx" and x[3:4] == bytes([84])] == sent
    # the joint-interpolated move to the same point is fine
    assert sim.until(sim.arm.move_ptp(P.PTPMode.MOVJ_XYZ, b)).status is MotionStatus.DONE
