"""open-dobot firmware: byte-exact codec, and the driver against the emulator over a pty."""

from __future__ import annotations

import numpy as np
import pytest
from arm_fixtures import ArmSim, connected
from hypothesis import given
from hypothesis import strategies as st

from armtree.api.clock import VirtualClock
from armtree.api.rig import MotionStatus
from armtree.errors import HardwareFault, Unreachable
from armtree.plugins.arms.common import sim_driver_options
from armtree.plugins.arms.dobot_v1 import opendobot as od
from armtree.plugins.arms.dobot_v1.driver import DobotV1Driver
from armtree.plugins.arms.dobot_v1.emulator import DobotV1Emulator
from armtree.plugins.arms.dobot_v1.kinematics import DobotV1Model
from armtree.plugins.arms.dobot_v1.opendobot_driver import OpenDobotDriver
from armtree.plugins.arms.dobot_v1.opendobot_emulator import OpenDobotEmulator
from armtree.plugins.arms.dobot_v1.plugin import dobot_v1_factory

H = bytes.fromhex

# ------------------------------------- codec (vectors computed from open-dobot's algorithm)


@pytest.mark.parametrize(
    ("cmd", "payload", "wire_request", "answer", "wire_reply"),
    [
        (od.READY, b"", "00 E1 F0", b"\x40", "40 55 CB"),
        (od.BOARD_VERSION, b"", "0C 20 7C", b"\x00", "00 58 62"),
        (od.BOARD_VERSION, b"", "0C 20 7C", b"\x01", "01 48 43"),
        (od.EMERGENCY_STOP, b"", "06 81 36", b"", "81 36"),
        (
            od.GET_COUNTERS,
            b"",
            "08 60 F8",
            od.counters_payload(0, 1000, -500),
            "00 00 00 00 00 00 03 E8 FF FF FE 0C A1 15",
        ),
        (
            od.STEPS,
            od.steps_payload(od.RAMPS, (100, 0, 0), (1, 0, 0), 2960, 2000),
            "01 C8 00 00 00 00 00 00 00 00 00 00 00 01 90 0B D0 07 43 79",
            b"\x01",
            "01 11 86",
        ),
    ],
)
def test_reference_vectors(cmd, payload, wire_request, answer, wire_reply):
    frame, crc = od.request(cmd, payload)
    assert frame == H(wire_request)
    assert od.reply(answer, crc) == H(wire_reply)
    assert od.check_reply(H(wire_reply), crc) == answer


def test_fpga_stop_value_is_sent_unswapped():
    assert od.FPGA.steps_value(0) == H("02 42 F0 00")
    assert od.FPGA.steps_of(H("02 42 F0 00")) == 0


@given(st.integers(1, 120))
def test_step_encoding_round_trips_on_both_boards(n):
    for board in (od.FPGA, od.RAMPS):
        assert board.steps_of(board.steps_value(n)) == n


@given(st.binary(max_size=40))
def test_corrupted_reply_never_passes_the_crc(data):
    frame, crc = od.request(od.GET_COUNTERS)
    good = od.reply(od.counters_payload(1, 2, 3), crc)
    if data != good[: len(data)] or len(data) != len(good):
        assert od.check_reply(data, crc) in (None, data[:-2])
        if od.check_reply(data, crc) is not None:
            assert od.crc_ccitt(data[:-2], crc).to_bytes(2, "big") == data[-2:]


# ---------------------------------------------------------------- driver <-> emulator


class Sim(ArmSim):
    limit = 600

    def __init__(self, **config):
        super().__init__(dobot_v1_factory, {"port": "sim", "firmware": "open-dobot", **config})


@pytest.fixture(params=["fpga", "ramps"])
def sim(request):
    yield from connected(Sim(board=request.param, start_pose=[0.0, 12.0, 52.0]))


def test_start_up_pose_comes_from_the_accelerometers(sim):
    assert isinstance(sim.arm, OpenDobotDriver) and isinstance(sim.emu, OpenDobotEmulator)
    q = sim.arm.joints()
    assert np.allclose(q, [0.0, 12.0, 52.0], atol=0.2)
    assert np.allclose(sim.emu.reported_joints(), q)


def test_move_streams_slots_and_completes_from_counters(sim):
    target = np.array([30.0, 8.0, 50.0])
    handle = sim.arm.move_joints(target)
    progress = sim.progress_until_done(handle)
    assert handle.status is MotionStatus.DONE
    assert np.all(np.diff(progress) >= -1e-9)
    assert np.allclose(sim.arm.joints(), target, atol=1 / od.STEPS_PER_DEG)
    # the true pose is off by the accelerometer's error, no more
    assert np.allclose(sim.emu.true_joints(), target, atol=0.2)


def test_consecutive_moves_and_suction_in_order(sim):
    a = sim.arm.move_joints([10.0, 5.0, 45.0])
    on = sim.arm.set_suction(True)
    b = sim.arm.move_joints([-10.0, 5.0, 45.0])
    sim.until(b)
    assert a.status is MotionStatus.DONE and on.status is MotionStatus.DONE
    assert sim.emu.tool().suction
    off = sim.arm.set_suction(False)
    sim.until(off)
    sim.tick(2)
    assert not sim.emu.tool().suction


def test_stop_sends_emergency_stop_and_the_arm_stays(sim):
    handle = sim.arm.move_joints([100.0, 5.0, 45.0])
    sim.tick(10)
    sim.arm.stop()
    assert handle.status is MotionStatus.STOPPED
    sim.tick(2)
    here = sim.emu.true_joints()
    sim.tick(20)
    assert np.allclose(sim.emu.true_joints(), here)
    assert 0.0 < sim.arm.joints()[0] < 100.0
    again = sim.arm.move_joints([0.0, 5.0, 45.0])
    sim.until(again)
    assert again.status is MotionStatus.DONE


def test_limit_switch_calibration_sets_the_counter(sim):
    handle = sim.arm.calibrate_joint(0, switch_angle=135.0, forward_hz=2000.0, back_hz=200.0)
    sim.until(handle, limit=2000)
    assert handle.status is MotionStatus.DONE
    assert sim.arm.joints()[0] == pytest.approx(135.0, abs=1 / od.STEPS_PER_DEG)
    # the joint stopped just off the switch
    assert 134.0 < sim.emu.true_joints()[0] < 135.0


def test_bad_targets_are_refused(sim):
    sent = sim.arm.requests_sent
    handle = sim.arm.move_joints([0.0, 30.0, 40.0])
    assert handle.status is MotionStatus.FAILED and isinstance(handle.error, Unreachable)
    assert sim.arm.requests_sent == sent


def test_bad_crc_is_silently_dropped_and_the_driver_retries(sim):
    frame, _ = od.request(od.READY)
    bad = frame[:-1] + bytes([frame[-1] ^ 0xFF])
    sim.arm.write(bad)
    sim.tick()
    assert sim.emu.rejected == 1
    sim.emu.inject("corrupt", count=1)
    handle = sim.arm.move_joints([5.0, 5.0, 45.0])
    sim.until(handle)
    assert handle.status is MotionStatus.DONE


@pytest.mark.timeout(60)  # a link re-asked for ever would hang here: the timeout fails it
def test_a_link_of_corrupt_replies_is_lost_not_asked_again_for_ever(sim):
    handle = sim.arm.move_joints([5.0, 5.0, 45.0])
    sim.emu.inject("corrupt", rate=1.0)  # every reply fails its CRC
    sim.tick(3)  # on the virtual clock each re-ask was answered at the same instant
    assert sim.interrupts and "link lost" in str(sim.interrupts[0][1])
    assert "fails its CRC" in str(sim.interrupts[0][1])
    assert handle.status is MotionStatus.FAILED and isinstance(handle.error, HardwareFault)


def test_queue_holds_99_entries():
    clock = VirtualClock()
    emu = OpenDobotEmulator(DobotV1Model(), clock)
    emu.start()
    try:
        replies = []
        emu.send = replies.append
        for _ in range(100):
            frame, _ = od.request(od.STEPS, od.steps_payload(od.FPGA, (1, 0, 0), (1, 0, 0), 480, 0))
            emu.on_bytes(frame, 0.0)
        assert [r[0] for r in replies].count(1) == 99 and replies[-1][0] == 0
    finally:
        emu.close()


def test_link_cut_mid_move(sim):
    handle = sim.arm.move_joints([60.0, 5.0, 45.0])
    sim.tick(5)
    sim.emu.inject("cut")
    assert handle.wait(2.0)
    assert isinstance(handle.error, HardwareFault) and sim.interrupts


def test_original_driver_on_open_dobot_says_no_status_frames():
    clock = VirtualClock()
    emu = OpenDobotEmulator(DobotV1Model(), clock)
    path = emu.start()
    drv = DobotV1Driver(
        DobotV1Model(), path, baud=115200, clock=clock, connect_timeout=0.3,
        **sim_driver_options(emu),
    )  # fmt: skip
    try:
        with pytest.raises(HardwareFault, match="no answer: expected Dobot V1.0 status frames"):
            drv.connect()
    finally:
        drv.close()
        emu.close()


def test_open_dobot_driver_on_original_firmware_names_it():
    clock = VirtualClock()
    emu = DobotV1Emulator(DobotV1Model(), clock)
    path = emu.start()
    drv = OpenDobotDriver(
        DobotV1Model(), path, baud=9600, clock=clock, connect_timeout=0.3,
        **sim_driver_options(emu),
    )  # fmt: skip
    try:
        with pytest.raises(HardwareFault, match="original firmware") as err:
            drv.connect()
        assert err.value.device == path
    finally:
        drv.close()
        emu.close()


def test_two_open_dobot_runs_exchange_identical_bytes():
    def run():
        with Sim(board="fpga", start_pose=[5.0, 10.0, 50.0]) as s:
            s.arm.connect()
            s.until(s.arm.move_joints([25.0, 8.0, 48.0]))
            s.until(s.arm.set_suction(True))
            s.until(s.arm.move_joints([-15.0, 3.0, 55.0]))
            return list(s.emu.transcript), s.arm.joints().tolist()

    first, second = run(), run()
    assert first == second
    assert len(first[0]) > 50


def test_silent_link_is_lost_on_the_run_clock(sim):
    handle = sim.arm.move_joints([40.0, 5.0, 45.0])
    sim.tick(3)
    sim.emu.inject("cut", silent=1)
    sim.tick(40)
    assert handle.wait(2.0)
    assert handle.status is MotionStatus.FAILED
    assert "link lost" in str(handle.error) and handle.error.device == sim.arm.device
    assert sim.interrupts and sim.interrupts[0][1] is handle.error
