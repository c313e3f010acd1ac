"""The shared pty emulator and serial driver bases, on a toy protocol.

Toy firmware: every 50 ms it sends a status frame ``A5 <n> <last cmd> 5A``;
the toy host answers each status frame with one command frame ``A5 <n> 00 5A``.
"""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest
import serial

from armtree.api.clock import VirtualClock, WallClock
from armtree.api.rig import MotionHandle, MotionStatus
from armtree.errors import HardwareFault
from armtree.maths.motion.kinematics import Joint, KinematicModel
from armtree.plugins.arms.common import (
    FixedFrameParser,
    PtyEmulator,
    SerialArmDriver,
    open_serial_port,
    sim_driver_options,
)


class OneJoint(KinematicModel):
    name = "toy"
    joints = (Joint("j", "revolute", -90, 90, max_speed=10, max_accel=20),)
    home = np.zeros(1)

    def link_frames(self, q):
        q = np.asarray(q, dtype=float)
        out = np.broadcast_to(np.eye(4), q.shape[:-1] + (1, 4, 4)).copy()
        out[..., 0, 0, 3] = q[..., 0]
        return out

    def ik_all(self, target):
        return np.asarray(target, dtype=float)[..., None, :1]


class ToyEmulator(PtyEmulator):
    period = 0.05

    def on_start(self):
        self.count = 0
        self.last_cmd = 0
        self.commands: list[tuple[float, int]] = []
        self.parser = FixedFrameParser(b"\xa5", 4, b"\x5a")
        self._next = self.time

    def on_bytes(self, data, t):
        for frame in self.parser.feed(data):
            self.last_cmd = frame[1]
            self.commands.append((t, frame[1]))

    def next_event_time(self):
        return self._next

    def on_timer(self, t):
        while self._next <= t + 1e-12:
            self.count = (self.count + 1) % 256
            self.send(bytes([0xA5, self.count, self.last_cmd, 0x5A]))
            self._next += self.period

    def tool(self):
        from armtree.api.rig import ToolState

        return ToolState()


class ToyDriver(SerialArmDriver):
    protocol = "toy status frames"

    def on_open(self):
        self.parser = FixedFrameParser(b"\xa5", 4, b"\x5a")
        self.frames: list[tuple[float, bytes]] = []

    def on_data(self, data):
        for frame in self.parser.feed(data):
            self.mark_alive()
            self.frames.append((self.now, frame))
            self.write(bytes([0xA5, frame[1], 0, 0x5A]))

    def joints(self):
        return np.zeros(1)

    def move_joints(self, q, speed=1.0):
        return MotionHandle("toy")

    def set_suction(self, on):
        return MotionHandle("toy")

    def stop(self):
        pass


def _pair(clock, **kw):
    emu = ToyEmulator(OneJoint(), clock)
    path = emu.start()
    drv = ToyDriver(OneJoint(), path, baud=9600, clock=clock, **sim_driver_options(emu), **kw)
    return emu, drv


def _run(ticks=20):
    clock = VirtualClock()
    emu, drv = _pair(clock)
    try:
        drv.connect()
        for _ in range(ticks):
            now = clock.advance(0.03)
            emu.step(now)
            # the barrier: everything sent has been handled and answered
            assert len(drv.frames) == emu.count
            assert len(emu.commands) == emu.count
        return list(emu.transcript), [(t, f) for t, f in drv.frames]
    finally:
        drv.close()
        emu.close()


def test_step_barrier_makes_the_exchange_deterministic():
    first = _run()
    second = _run()
    assert first == second
    assert len(first[1]) == round(20 * 0.03 / 0.05) + 1


def test_wall_clock_emulator_serves_itself():
    clock = WallClock()
    emu, drv = _pair(clock)
    try:
        drv.connect()
        got = threading.Event()
        deadline = 5.0
        while not got.is_set() and deadline > 0:
            got.wait(0.05)
            deadline -= 0.05
            if len(drv.frames) >= 3:
                got.set()
        assert got.is_set()
    finally:
        drv.close()
        emu.close()


def test_missing_port_is_a_hardware_fault_naming_it():
    with pytest.raises(HardwareFault) as err:
        open_serial_port("/dev/does-not-exist-armtree", 9600)
    assert err.value.device == "/dev/does-not-exist-armtree"
    assert "no such serial port" in str(err.value)


def test_busy_port_is_a_hardware_fault():
    clock = VirtualClock()
    emu = ToyEmulator(OneJoint(), clock)
    path = emu.start()
    first = open_serial_port(path, 9600)
    try:
        with pytest.raises(HardwareFault, match="busy"):
            open_serial_port(path, 9600)
    finally:
        first.close()
        emu.close()


def test_regular_file_is_not_a_serial_port(tmp_path):
    f = tmp_path / "notatty"
    f.write_text("x")
    with pytest.raises(HardwareFault, match="not a serial port|cannot open"):
        open_serial_port(str(f), 9600)


def test_silent_device_gives_no_answer_error():
    clock = VirtualClock()
    emu = ToyEmulator(OneJoint(), clock)
    path = emu.start()
    emu.inject("cut", silent=1)
    drv = ToyDriver(OneJoint(), path, baud=9600, clock=clock, connect_timeout=0.3)
    try:
        with pytest.raises(HardwareFault, match="no answer"):
            drv.connect()
    finally:
        emu.close()


def test_foreign_banner_is_named():
    master, slave = os.openpty()
    path = os.ttyname(slave)

    class BootingBoard(ToyDriver):
        def on_open(self):
            super().on_open()
            # a Mega resets when the port opens and then prints its banner
            os.write(master, b"start\necho:Marlin 1.1.9\n")

    drv = BootingBoard(OneJoint(), path, baud=115200, clock=WallClock(), connect_timeout=0.3)
    try:
        with pytest.raises(HardwareFault, match="Marlin") as err:
            drv.connect()
        assert err.value.device == path
    finally:
        os.close(master)
        os.close(slave)


def test_cut_link_fails_handles_and_interrupts():
    clock = VirtualClock()
    reasons = []
    emu, drv = _pair(clock, interrupt=lambda reason, fault=None: reasons.append((reason, fault)))
    try:
        drv.connect()
        handle = drv.track(MotionHandle("move"))
        emu.step(clock.advance(0.1))
        emu.inject("cut")
        assert handle.wait(2.0)
        assert handle.status is MotionStatus.FAILED
        assert isinstance(handle.error, HardwareFault) and handle.error.device == drv.device
        assert reasons and reasons[0][0] == f"link lost on {drv.device}"
    finally:
        drv.close()
        emu.close()


def test_silent_link_is_detected_by_the_watchdog_on_the_run_clock():
    clock = VirtualClock()
    lost = threading.Event()
    emu, drv = _pair(clock, link_timeout=0.5, interrupt=lambda reason, fault=None: lost.set())
    try:
        drv.connect()
        emu.step(clock.advance(0.1))
        emu.inject("cut", silent=1)
        for _ in range(10):
            emu.step(clock.advance(0.1))
        assert lost.wait(2.0)
        assert "no toy status frames" in str(drv.fault)
        assert drv.fault.device == drv.device
    finally:
        drv.close()
        emu.close()


def test_corrupt_and_drop_faults_change_the_bytes_deterministically():
    def run():
        clock = VirtualClock()
        emu, drv = _pair(clock)
        try:
            drv.connect()
            emu.inject("corrupt", rate=0.2)
            for _ in range(20):
                emu.step(clock.advance(0.05))
            return [f for _, f in drv.frames], drv.parser.discarded
        finally:
            drv.close()
            emu.close()

    a, b = run(), run()
    assert a == b
    assert a[1] > 0


def test_unknown_fault_is_refused():
    emu = ToyEmulator(OneJoint(), VirtualClock())
    with pytest.raises(ValueError, match="unknown fault"):
        emu.inject("gremlins")


def test_serial_module_is_pyserial():
    assert hasattr(serial, "Serial")


def test_dropped_bytes_lose_frames_and_the_parser_resynchronises():
    clock = VirtualClock()
    emu, drv = _pair(clock)
    try:
        drv.connect()
        emu.step(clock.advance(0.05))
        before = len(drv.frames)
        emu.inject("drop", count=2)
        for _ in range(4):
            emu.step(clock.advance(0.05))
        # the frame that lost two bytes is gone; every later one is parsed again
        assert len(drv.frames) == before + 3
        assert all(f[0] == 0xA5 and f[-1] == 0x5A for _, f in drv.frames)
    finally:
        drv.close()
        emu.close()


def test_busy_port_through_a_driver():
    clock = VirtualClock()
    emu, first = _pair(clock)
    second = ToyDriver(OneJoint(), emu.path, baud=9600, clock=clock)
    try:
        first.connect()
        with pytest.raises(HardwareFault, match="busy") as err:
            second.connect()
        assert err.value.device == emu.path
    finally:
        first.close()
        emu.close()


def test_a_driver_bug_becomes_a_hardware_fault_not_a_hang():
    clock = VirtualClock()
    reasons = []

    class Buggy(ToyDriver):
        def on_data(self, data):
            super().on_data(data)
            if len(self.frames) >= 3:
                raise KeyError("oops")

    emu = ToyEmulator(OneJoint(), clock)
    path = emu.start()
    drv = Buggy(
        OneJoint(),
        path,
        baud=9600,
        clock=clock,
        interrupt=lambda reason, fault=None: reasons.append(fault),
        **sim_driver_options(emu),
    )
    try:
        drv.connect()
        for _ in range(5):
            emu.step(clock.advance(0.05))
        assert drv.fault is not None and "KeyError" in str(drv.fault)
        assert reasons == [drv.fault]
    finally:
        drv.close()
        emu.close()


class _DrainInterrupted:
    """A port whose drain a signal interrupts ``times`` times, then fails with ``final``."""

    def __init__(self, times: int, final: int | None = None) -> None:
        self.times, self.final, self.flushes = times, final, 0

    def write(self, data):
        return len(data)

    def flush(self):
        import errno
        import termios

        self.flushes += 1
        if self.flushes <= self.times:
            raise termios.error(errno.EINTR, "Interrupted system call")
        if self.final is not None:
            raise termios.error(self.final, "Input/output error")


def test_a_signal_interrupting_the_drain_is_retried_not_taken_for_a_lost_link():
    # Ctrl-C landing on the driver's thread while it drains must end the run as an
    # interrupt (130), not a lost link (exit 3)
    clock = VirtualClock()
    emu, drv = _pair(clock)
    try:
        drv.connect()
        port = _DrainInterrupted(times=2)
        real, drv._ser = drv._ser, port
        assert drv.write(b"x") is True
        assert port.flushes == 3 and drv.fault is None
        port = _DrainInterrupted(times=0, final=5)  # EIO: the device is gone
        drv._ser = port
        assert drv.write(b"x") is False
        assert drv.fault is not None and "link lost while writing" in str(drv.fault)
        drv._ser = real
    finally:
        drv.close()
        emu.close()
