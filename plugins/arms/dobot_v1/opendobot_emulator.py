"""The open-dobot replacement firmware (open-dobot) behind a pseudo-terminal.

Strict request/response with CRC-16/CCITT continuing into the reply; a bad
CRC or unknown id silently drops the buffered bytes. A 100-slot queue (99
usable) runs one STEPS entry per 20 ms slot on the run clock, with pump,
valve and laser entries executed between slots; an empty queue stops the
motors and forces the laser off. Step counters are what the firmware knows;
the arm's true pose starts at ``q0`` (read by the accelerometers at boot) and
moves by the steps issued, so the host's idea of the pose is only as good as
its accelerometer reading, as on the real arm. The limit-switch routine moves
a joint toward its switch, backs off until released and stops. Angles in
degrees.
"""

from __future__ import annotations

import collections
import math
import struct

import numpy as np

from armtree.api.clock import Clock
from armtree.api.rig import ToolState

from ..common import PtyEmulator
from . import opendobot as od
from .kinematics import DobotV1Model

#: Where the limit switch of each joint sits (degrees, true angle), and its hysteresis.
SWITCH_ANGLES = (135.0, 85.0, 95.0)
SWITCH_HYSTERESIS = 0.5
#: The firmware's receive buffer (open-dobot firmware).
RX_BUFFER = 24


class OpenDobotEmulator(PtyEmulator):
    """The open-dobot firmware on an FPGA (default) or RAMPS board."""

    def __init__(
        self,
        model: DobotV1Model,
        clock: Clock,
        *,
        seed: int = 0,
        q0: np.ndarray | None = None,
        board: str = "fpga",
        switch_angles: tuple[float, float, float] = SWITCH_ANGLES,
    ) -> None:
        super().__init__(model, clock, seed=seed, q0=q0)
        if board not in od.BOARDS:
            raise ValueError(f"open-dobot board {board!r} is not one of {', '.join(od.BOARDS)}")
        self.board = od.BOARDS[board]
        self.switch_angles = switch_angles
        self.counters = [0, 0, 0]
        self.pump = False
        self.valve = False
        self.laser = False
        self.grab_pwm = 0
        self.rot_pwm = 0
        #: Requests dropped for a bad CRC, an unknown id or a full receive buffer.
        self.rejected = 0
        self._q0 = np.asarray(model.home if q0 is None else q0, dtype=float).copy()
        self._moved = np.zeros(3)
        self._queue: collections.deque[tuple] = collections.deque()
        self._rx = bytearray()
        self._boot = 0.0
        self._next_slot = 0.0
        self._boot_accels = b""
        self._calib: dict | None = None

    # ------------------------------------------------------------------ state

    def on_start(self) -> None:
        """Boot: the FPGA board reads its accelerometers once, now."""
        self._boot = self._next_slot = self.time
        self._boot_accels = self._accels()

    def true_joints(self) -> np.ndarray:
        """Where the arm is: the boot pose moved by every step issued, plus missed steps."""
        with self._lock:
            return self._q0 + self._moved + self.joints.missed

    def reported_joints(self) -> np.ndarray:
        """The step counters as angles (what a host reading GET_COUNTERS believes)."""
        with self._lock:
            return np.array(self.counters, dtype=float) / od.STEPS_PER_DEG

    def tool(self) -> ToolState:
        """Suction holds while the pump runs with the valve closed."""
        return ToolState(suction=self.pump and not self.valve, gripper=float(self.grab_pwm))

    def halt(self, reason: str) -> None:
        """An e-stop: the queue and the calibrator are cleared."""
        with self._lock:
            self._queue.clear()
            self._calib = None
            self.halted_reason = reason

    # ------------------------------------------------------------------ timing

    def next_event_time(self) -> float | None:
        """The next 20 ms slot while there is work queued or a calibration running."""
        if self._queue or self._calib is not None:
            return self._next_slot
        return None

    def on_timer(self, t: float) -> None:
        """Run every slot due by ``t``."""
        while self._next_slot <= t + 1e-12:
            if not self._queue and self._calib is None:
                # idle: jump to the next slot boundary after t
                k = math.floor((t - self._boot) / od.SLOT + 1e-9) + 1
                self._next_slot = self._boot + k * od.SLOT
                self.laser = False
                return
            self._slot()
            self._next_slot += od.SLOT

    def _slot(self) -> None:
        if self._calib is not None:
            self._calibration_slot(self._calib)
            return
        while self._queue and self._queue[0][0] != od.STEPS:
            self._action(self._queue.popleft())
        if self._queue:
            _, steps, dirs = self._queue.popleft()
            for j in range(3):
                self._step(j, steps[j], dirs[j])
        while self._queue and self._queue[0][0] != od.STEPS:
            self._action(self._queue.popleft())
        if not self._queue:
            self.laser = False

    def _step(self, joint: int, n: int, direction: int) -> None:
        """Issue ``n`` steps on ``joint``; the forearm counter runs the other way (open-dobot firmware)."""
        if n <= 0:
            return
        sign = 1 if direction else -1
        if joint == 2:
            sign = -sign
        self.counters[joint] += sign * n
        self._moved[joint] += sign * n / od.STEPS_PER_DEG

    def _action(self, entry: tuple) -> None:
        cmd, on = entry
        if cmd == od.PUMP_ON:
            self.pump = on
        elif cmd == od.VALVE_ON:
            self.valve = on
        elif cmd == od.LASER_ON:
            self.laser = on

    def _calibration_slot(self, c: dict) -> None:
        j = c["joint"]
        angle = self.true_joints()[j]
        switch = self.switch_angles[j]
        toward = 1 if c["toward"] else -1
        # the side of the switch the joint moves toward (counter direction == angle direction)
        sign_toward = toward if j != 2 else -toward
        pressed = (angle - switch) * sign_toward >= 0
        if c["state"] == 1:
            if pressed:
                c["state"] = 2
            else:
                self._step(j, c["forward"], int(toward > 0))
                return
        released = (angle - switch) * sign_toward < -SWITCH_HYSTERESIS
        if released:
            self._calib = None
            return
        self._step(j, c["back"], int(toward < 0))

    # ------------------------------------------------------------------ requests

    def on_bytes(self, data: bytes, t: float) -> None:
        """Buffer bytes and answer each complete request."""
        for byte in data:
            if len(self._rx) >= RX_BUFFER:
                self.rejected += 1
                self._rx.clear()
            self._rx.append(byte)
            cmd = self._rx[0]
            if cmd not in od.REQUEST_LEN:
                self.rejected += 1
                self._rx.clear()
                continue
            need = 1 + od.REQUEST_LEN[cmd] + 2
            if len(self._rx) < need:
                continue
            frame = bytes(self._rx[:need])
            self._rx.clear()
            crc = od.crc_ccitt(frame[:-2])
            if crc.to_bytes(2, "big") != frame[-2:]:
                self.rejected += 1
                continue
            answer = self._handle(cmd, frame[1:-2])
            if answer is not None:
                self.send(od.reply(answer, crc))

    def _handle(self, cmd: int, payload: bytes) -> bytes | None:
        if cmd == od.READY:
            return bytes([od.READY_MAGIC])
        if cmd == od.BOARD_VERSION:
            return bytes([self.board.version])
        if cmd in (od.GET_ACCELS, od.SWITCH_TO_ACCEL_REPORT_MODE):
            return self._boot_accels if self.board is od.FPGA else self._accels()
        if cmd == od.GET_COUNTERS:
            return od.counters_payload(*self.counters)
        if cmd == od.SET_COUNTERS:
            self.counters = list(struct.unpack(">iii", payload))
            return b""
        if cmd == od.STEPS:
            if self._queue_full():
                return b"\x00"
            steps = tuple(self.board.steps_of(payload[4 * j : 4 * j + 4]) for j in range(3))
            control = payload[12]
            dirs = tuple((control >> j) & 1 for j in range(3))
            self.grab_pwm, self.rot_pwm = struct.unpack("<HH", payload[13:17])
            self._queue.append((od.STEPS, steps, dirs))
            return b"\x01"
        if cmd in (od.PUMP_ON, od.VALVE_ON, od.LASER_ON):
            if self._queue_full():
                return b"\x00"
            self._queue.append((cmd, payload[0] != 0))
            return b"\x01"
        if cmd == od.EMERGENCY_STOP:
            self._queue.clear()
            self._calib = None
            return b""
        if cmd == od.CALIBRATE_JOINT:
            forward, back = struct.unpack("<II", payload[:8])
            control = payload[9]
            joint = control & 3
            self._queue.clear()
            if joint < 3:
                raw = lambda v: self.board.steps_of(struct.pack("<I", v))  # noqa: E731
                self._calib = {
                    "joint": joint,
                    "toward": (control >> 2) & 1,
                    "forward": raw(forward),
                    "back": raw(back),
                    "state": 1,
                }
                self._next_slot = max(self._next_slot, self.time)
            return b""
        if cmd == od.CALIBRATOR_STATUS:
            return bytes([0 if self._calib is None else self._calib["state"]])
        if cmd == od.EXEC_QUEUE:
            return None
        return None

    def _queue_full(self) -> bool:
        return len(self._queue) >= od.QUEUE_SIZE - 1

    def _accels(self) -> bytes:
        """Accelerometer readings for the true pose (FPGA: X channels; RAMPS: MPU-6050 g vectors)."""
        q = np.radians(self.true_joints())
        if self.board is od.FPGA:
            # asin((raw - 1024) / 493.56) = pi/2 - rear for the rear arm, = front for the forearm
            rear = round(od.ACCEL_ZERO + od.ACCEL_SCALE * math.cos(q[1]))
            front = round(od.ACCEL_ZERO + od.ACCEL_SCALE * math.sin(q[2]))
            return struct.pack(">6h", rear, 0, 0, front, 0, 0)
        g = 16384.0
        rear_g = (g * math.cos(q[1]), 0.0, g * math.sin(q[1]))
        front_g = (-g * math.sin(q[2]), 0.0, g * math.cos(q[2]))
        return struct.pack(">6h", *(round(v) for v in rear_g + front_g))
