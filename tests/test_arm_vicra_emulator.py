"""The Marlin emulator byte for byte: keep-alives, relative moves, G92, M18, a full planner."""

from __future__ import annotations

import select
import time

import numpy as np
import pytest
import serial

from armtree.api.clock import VirtualClock
from armtree.plugins.arms.vicra import gcode as G
from armtree.plugins.arms.vicra.emulator import BLOCK_BUFFER_SIZE, MarlinEmulator
from armtree.plugins.arms.vicra.kinematics import VicraModel


class Bench:
    """The emulator on a virtual clock and a raw pyserial port on its pty (no driver)."""

    def __init__(self, q0=None):
        self.clock = VirtualClock()
        self.emu = MarlinEmulator(VicraModel(), self.clock, q0=q0)
        self.port = serial.Serial(self.emu.start(), 115200, timeout=0)
        self.n = 0
        self.sent = 0
        self.send("M110 N0", number=False)
        self.read()

    def send(self, command: str, number: bool = True) -> None:
        if number:
            self.n += 1
            line = G.numbered(self.n, command)
        else:
            line = command
        data = (line + "\n").encode()
        self.port.write(data)
        self.sent += len(data)
        # A pty hands bytes over asynchronously: step at the same instant until the
        # firmware has them, as the driver's barrier would make sure of.
        deadline = time.monotonic() + 2.0
        while self.received() < self.sent and time.monotonic() < deadline:
            self.emu.step(self.clock.now())
            select.select([], [], [], 0.001)

    def received(self) -> int:
        return sum(len(d) for _, way, d in self.emu.transcript if way == "rx")

    def available(self) -> str:
        """Everything the firmware has said so far, allowing the pty a moment to deliver."""
        data = b""
        while select.select([self.port.fileno()], [], [], 0.01)[0]:
            chunk = self.port.read(4096)
            if not chunk:
                break
            data += chunk
        return data.decode()

    def run(self, seconds: float, dt: float = 0.05) -> None:
        for _ in range(int(round(seconds / dt))):
            self.emu.step(self.clock.advance(dt))

    def read(self) -> list[str]:
        self.run(0.05)
        return self.available().splitlines()

    def close(self):
        self.port.close()
        self.emu.close()


@pytest.fixture
def bench():
    b = Bench(q0=np.array([100.0, 0.0, 0.0, 0.0]))
    yield b
    b.close()


def test_homing_from_afar_prints_keepalives_and_ok_only_when_done(bench):
    bench.send("G28")
    out = []
    for _ in range(200):
        out += bench.read()
        if "ok" in out:
            break
    assert out.count("echo:busy: processing") >= 2  # every 2 s while it homes
    assert out[-1] == "ok" and bench.emu.homed
    np.testing.assert_allclose(bench.emu.true_joints(), bench.emu.model.park, atol=1e-9)


def test_relative_moves_g92_and_m18(bench):
    bench.send("G28")
    while "ok" not in bench.read():
        pass
    bench.send("G91")
    bench.send("G1 X10 Y-20 Z-100 F6000")
    bench.send("M400")
    bench.send("M114")
    out = []
    while not any(G.parse_m114(x) for x in out):
        out += bench.read()
    pos = next(G.parse_m114(x) for x in out if G.parse_m114(x))
    assert (pos.axes["X"], pos.axes["Y"], pos.axes["Z"]) == (-150.0, 130.0, 500.0)
    assert pos.counts == {"X": -6000, "Y": 5200, "Z": 200000}
    bench.send("G92 X0")
    bench.send("M114")
    out = bench.read()
    assert any(x.startswith("X:0.00 Y:130.00") for x in out)
    bench.send("M18")
    bench.send("G90")
    bench.send("G1 X5")
    assert "echo:Home XYZ First" in bench.read()  # released steppers lose their position


def test_a_full_planner_holds_back_the_ok(bench):
    bench.send("G28")
    while "ok" not in bench.read():
        pass
    # one line at a time, as a host keeps to the receive buffer: each G1 is planned and
    # answered until the 16-block planner is full (one block already running)
    answered = 0
    for k in range(BLOCK_BUFFER_SIZE + 3):
        bench.send(f"G1 Z{500 - 10 * (k % 2)} F600")
        bench.emu.step(bench.clock.now())
        got = bench.available().count("ok")
        if not got:
            break
        answered += got
    assert answered == BLOCK_BUFFER_SIZE + 1
    bench.run(12.0)  # the first block (100 mm at 10 mm/s) ends: the waiting line is answered
    assert bench.available().count("ok") == 1


def test_unknown_command_and_servo_errors(bench):
    bench.send("M9999")
    bench.send("M280 P7 S10")
    bench.send("M280 P1")
    out = bench.read()
    assert out == [
        'echo:Unknown command: "M9999"',
        "ok",
        "Error:Servo 7 out of range",
        "ok",
        "echo: Servo 1: 90",
        "ok",
    ]
