"""The servo bus emulators driven by the vendors' own Python clients, as an outside program would.

``scservo_sdk`` (Feetech's SDK, what LeRobot drives an SO-101 with) and
``dynamixel_sdk`` (ROBOTIS's, a Koch's) open the emulator's pty like a USB adapter
and ping, read, write, sync write and sync read; the emulator also loses replies,
answers late and trips a servo's overload protection when asked.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import dynamixel_sdk as dxl
import numpy as np
import pytest
import scservo_sdk as scs

from armtree.api.clock import WallClock
from armtree.maths.motion.kinematics import Joint, KinematicModel
from armtree.plugins.arms.bus_servo.emulator import BusServoEmulator, Mount
from armtree.plugins.arms.bus_servo.servo import SimServo
from armtree.plugins.arms.bus_servo.tables import MODELS, protocol_for

IDS = range(1, 7)


class SixJoints(KinematicModel):
    """Five arm joints and nothing else: the bus does not care about geometry."""

    def __init__(self) -> None:
        self.joints = tuple(Joint(f"j{i}", "revolute", -150.0, 150.0) for i in range(5))
        self.home = np.zeros(5)

    def link_frames(self, q):
        return np.broadcast_to(np.eye(4), (*np.shape(q)[:-1], 2, 4, 4))

    def ik_all(self, target):
        return np.full((1, 5), np.nan)


@contextmanager
def served(bus: str, model: str, **options):
    """An emulated bus (ids 1-6, horns at 2048 + 10 * id) on the wall clock, and its pty."""
    servos = [SimServo(MODELS[model], i, 2048 + 10 * i) for i in IDS]
    emulator = BusServoEmulator(
        SixJoints(),
        WallClock(),
        protocol_for(bus),
        servos,
        [Mount(i, 2048) for i in range(1, 6)],
        gripper=Mount(6, 2048),
        **options,
    )
    path = emulator.start()
    try:
        yield emulator, path
    finally:
        emulator.close()


def open_port(sdk, path: str):
    port = sdk.PortHandler(path)
    assert port.openPort() and port.setBaudRate(1_000_000)
    # LeRobot patches the PyPI SDKs' packet timeout (34 ms at 1 Mbaud) the same way: a
    # machine shared by several test runs may take longer to schedule the emulator.
    default = port.setPacketTimeout
    port.setPacketTimeout = lambda n: (default(n), setattr(port, "packet_timeout", 500.0))
    return port


def wait_until(condition, timeout=5.0):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_the_feetech_sdk_pings_reads_writes_and_syncs_the_sts3215_bus():
    with served("feetech", "sts3215") as (emu, path):
        port, ph = open_port(scs, path), scs.PacketHandler(0)
        try:
            assert ph.ping(port, 1) == (777, scs.COMM_SUCCESS, 0)  # STS3215
            assert ph.ping(port, 9)[1] == scs.COMM_RX_TIMEOUT  # nobody there
            assert ph.read2ByteTxRx(port, 3, 56) == (2078, scs.COMM_SUCCESS, 0)
            assert ph.read1ByteTxRx(port, 3, 6) == (0, scs.COMM_SUCCESS, 0)  # 1,000,000 baud
            assert ph.write1ByteTxRx(port, 3, 40, 1) == (scs.COMM_SUCCESS, 0)
            assert ph.write2ByteTxRx(port, 3, 42, 2500) == (scs.COMM_SUCCESS, 0)
            wait_until(lambda: ph.read2ByteTxRx(port, 3, 56)[0] == 2500)
            # the joint the servo turns moved with it: 2500 - 2048 counts
            assert emu.true_joints()[2] == pytest.approx(452 * 360 / 4096)

            writer = scs.GroupSyncWrite(port, ph, 40, 1)
            for i in IDS:
                writer.addParam(i, [1])
            assert writer.txPacket() == scs.COMM_SUCCESS
            goals = scs.GroupSyncWrite(port, ph, 42, 2)
            for i in IDS:
                goals.addParam(i, [scs.SCS_LOBYTE(1900 + i), scs.SCS_HIBYTE(1900 + i)])
            assert goals.txPacket() == scs.COMM_SUCCESS
            reader = scs.GroupSyncRead(port, ph, 56, 8)
            for i in IDS:
                reader.addParam(i)

            def arrived():
                assert reader.txRxPacket() == scs.COMM_SUCCESS
                return all(reader.getData(i, 56, 2) == 1900 + i for i in IDS)

            wait_until(arrived)
            # the block also carries voltage (0.1 V) and temperature (deg C)
            assert reader.getData(1, 62, 1) == 74 and 20 < reader.getData(1, 63, 1) < 60
        finally:
            port.closePort()


def test_the_dynamixel_sdk_pings_reads_writes_and_syncs_the_xl330_bus():
    with served("dynamixel", "xl330-m288") as (emu, path):
        port, ph = open_port(dxl, path), dxl.PacketHandler(2.0)
        try:
            assert ph.ping(port, 1) == (1200, dxl.COMM_SUCCESS, 0)  # XL330-M288
            found, result = ph.broadcastPing(port)
            assert result == dxl.COMM_SUCCESS and sorted(found) == list(IDS)
            assert ph.read4ByteTxRx(port, 2, 132) == (2068, dxl.COMM_SUCCESS, 0)
            # EEPROM (drive mode) is written with torque off; with torque on it is refused
            assert ph.write1ByteTxRx(port, 2, 10, 4) == (dxl.COMM_SUCCESS, 0)
            assert ph.write1ByteTxRx(port, 2, 64, 1) == (dxl.COMM_SUCCESS, 0)
            assert ph.write1ByteTxRx(port, 2, 10, 0) == (dxl.COMM_SUCCESS, 7)  # access error
            assert ph.read1ByteTxRx(port, 2, 10)[0] == 4

            writer = dxl.GroupSyncWrite(port, ph, 112, 8)  # profile velocity and goal position
            for i in IDS:
                writer.addParam(i, [*(0).to_bytes(4, "little"), *(2100 + i).to_bytes(4, "little")])
            assert writer.txPacket() == dxl.COMM_SUCCESS
            torque = dxl.GroupSyncWrite(port, ph, 64, 1)
            for i in IDS:
                torque.addParam(i, [1])
            assert torque.txPacket() == dxl.COMM_SUCCESS
            reader = dxl.GroupSyncRead(port, ph, 126, 10)
            for i in IDS:
                reader.addParam(i)

            def arrived():
                assert reader.txRxPacket() == dxl.COMM_SUCCESS
                return all(reader.getData(i, 132, 4) == 2100 + i for i in IDS)

            wait_until(arrived)
            assert emu.tool().gripper == pytest.approx((2106 - 2048) * 360 / 4096)
        finally:
            port.closePort()


def test_lost_replies_are_lost_and_counted():
    with served("feetech", "sts3215") as (emu, path):
        port, ph = open_port(scs, path), scs.PacketHandler(0)
        port.setPacketTimeout = lambda n: port.setPacketTimeoutMillis(60)
        try:
            emu.inject("lost_replies", count=2)
            assert ph.read2ByteTxRx(port, 1, 56)[1] == scs.COMM_RX_TIMEOUT
            assert ph.read2ByteTxRx(port, 1, 56)[1] == scs.COMM_RX_TIMEOUT
            assert ph.read2ByteTxRx(port, 1, 56) == (2058, scs.COMM_SUCCESS, 0)
            assert emu.lost_replies == 2
        finally:
            port.closePort()


def test_latency_delays_every_reply():
    with served("dynamixel", "xl430-w250", latency_s=0.15) as (_, path):
        port, ph = open_port(dxl, path), dxl.PacketHandler(2.0)
        try:
            start = time.monotonic()
            assert ph.ping(port, 4) == (1060, dxl.COMM_SUCCESS, 0)
            assert time.monotonic() - start >= 0.14  # the emulator's own steps: 2 ms
            port.setPacketTimeout = lambda n: port.setPacketTimeoutMillis(50)
            assert ph.ping(port, 4)[1] == dxl.COMM_RX_TIMEOUT  # the SDK gave up first
        finally:
            port.closePort()


@pytest.mark.parametrize(
    ("bus", "model", "sdk"), [("feetech", "sts3215", scs), ("dynamixel", "xl430-w250", dxl)]
)
def test_an_overloaded_servo_drops_its_torque_and_says_so(bus, model, sdk):
    with served(bus, model) as (emu, path):
        port = open_port(sdk, path)
        ph = sdk.PacketHandler(0) if sdk is scs else sdk.PacketHandler(2.0)
        torque = 40 if sdk is scs else 64
        try:
            assert ph.write1ByteTxRx(port, 2, torque, 1) == (sdk.COMM_SUCCESS, 0)
            emu.inject("overload", joint=1)
            wait_until(lambda: ph.ping(port, 2)[2] != 0)
            _, _, error = ph.ping(port, 2)
            assert "Overload" in ph.getRxPacketError(
                error
            ) or "Hardware error" in ph.getRxPacketError(error)
            assert ph.read1ByteTxRx(port, 2, torque)[0] == 0  # the protection took the torque
            if sdk is dxl:
                assert ph.read1ByteTxRx(port, 2, 70)[0] == 0x20  # Hardware Error Status: overload
            assert ph.ping(port, 1)[2] == 0  # its neighbours are fine
        finally:
            port.closePort()


BIN = Path(sys.executable).parent


@pytest.mark.skipif(
    not (BIN / "armtree").exists(), reason="the armtree console script is not installed"
)
@pytest.mark.parametrize(("arm", "sdk", "model"), [("so101", scs, 777), ("koch", dxl, 1060)])
def test_armtree_emulate_serves_the_arm_the_vendor_sdk_pings(arm, sdk, model):
    proc = subprocess.Popen(
        [str(BIN / "armtree"), "emulate", arm],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        path = proc.stdout.readline().strip()
        assert path.startswith("/dev/pts/"), proc.stderr.read()
        port = open_port(sdk, path)
        ph = sdk.PacketHandler(0) if sdk is scs else sdk.PacketHandler(2.0)
        try:
            found = [ph.ping(port, i) for i in range(1, 7)]
        finally:
            port.closePort()
        assert [f[1] for f in found] == [sdk.COMM_SUCCESS] * 6
        assert found[0][0] == model  # the shoulder pan: an STS3215, or the Koch's XL430
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 130
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.parametrize("model", ["sts3215", "xl430-w250"])
def test_a_knocked_servo_goes_back_to_its_goal_and_a_limp_one_stays(model):
    """A position-controlled servo holds its goal against a knock (its encoder is absolute:
    nothing is lost); with torque off the horn stays where the knock left it."""
    servo = SimServo(MODELS[model], 1, 2048)
    servo.mem[servo.model.register("torque_enable").address] = 1
    servo.slip(40, 1.0)
    assert servo.present(1.0) == pytest.approx(2088, abs=1e-6)
    assert servo.moving(1.0)
    assert servo.present(5.0) == pytest.approx(2048, abs=1e-6) and not servo.moving(5.0)
    servo.mem[servo.model.register("torque_enable").address] = 0
    servo.slip(-25, 6.0)
    assert servo.present(60.0) == pytest.approx(2023, abs=1e-6)
