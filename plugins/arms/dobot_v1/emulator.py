"""Firmware emulators of the Dobot V1.0: the original firmware and open-dobot.

:class:`DobotV1Emulator` speaks the original firmware's 42-byte frames
(Dobot protocol): a status frame every ``status_period`` seconds, state 3 / 6
moves in a small FIFO, jogs (axis 0 stops), suction, speed and playback
configuration, MOVJ / MOVL (a straight tool line) / JUMP moves, and the
documented quirk that a command arriving before the
next status frame was sent is dropped (Dobot protocol; the official client
writes one command per status frame).

Opening the port resets the board (the Arduino's DTR reset, Dobot protocol,
serial settings): after the first open, which finds the board booted at
power-up, every open reboots it (:meth:`DobotV1Emulator.reboot`). Queued moves
and the tool's state are lost, no status frame comes for ``boot_time``
seconds, and the firmware's believed rear-arm and forearm angles are read
again from the accelerometers (the V1.0's only pose sensors, open-dobot:
11-bit X readings, ``asin((raw - 1024) / 493.56)``), so missed steps of those
joints are undone up to the reading's quantisation; the base has no sensor
and is believed to be at 0.

:class:`OpenDobotEmulator` (in :mod:`.opendobot_emulator`) is the replacement firmware.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass

import numpy as np

from armtree.api.clock import Clock
from armtree.api.rig import ToolState
from armtree.errors import Unreachable

from ..common import PtyEmulator
from ..common.motion import LineMove
from . import codec
from . import opendobot as od
from .kinematics import DobotV1Model

#: Mechanical joint ranges of the V1.0 (Showers 2016, "Hardware"); the firmware clamps to these.
HARDWARE_LOWER = np.array([-135.0, -5.0, -10.0])
HARDWARE_UPPER = np.array([135.0, 85.0, 95.0])
#: Seconds from a reset (the port opened) to the first status frame: the Arduino's boot,
#: which drivers wait out (about 2 s, Dobot protocol, serial settings).
BOOT_TIME = 2.0
#: Power-up values of the firmware's motion settings (speed ratio, JUMP height mm,
#: MOVL speed mm/s and acceleration mm/s^2).
DEFAULT_SPEED_RATIO = 1.0
DEFAULT_JUMP_HEIGHT = 20.0
DEFAULT_LINEAR_SPEED = 100.0
DEFAULT_LINEAR_ACCEL = 400.0


def accelerometer_pose(q: np.ndarray) -> np.ndarray:
    """The pose the firmware believes at boot for true joints ``q`` (degrees).

    Rear arm and forearm from their accelerometers' 11-bit X readings as the
    FPGA board converts them (open-dobot: ``asin((raw - 1024) / 493.56)``, the
    rear arm ``90 deg - that``), so quantised to one count; the base, which has
    no sensor, is 0. The X channel alone cannot tell the rear arm's sign.
    """
    rear = math.radians(float(q[1]))
    fore = math.radians(float(q[2]))
    rear_raw = _counts(math.cos(rear))
    fore_raw = _counts(math.sin(fore))
    return np.array(
        [
            0.0,
            90.0 - math.degrees(od.accel_to_radians(rear_raw)),
            math.degrees(od.accel_to_radians(fore_raw)),
        ]
    )


def _counts(sine: float) -> int:
    """The 11-bit reading (0..2047) of an accelerometer whose X axis sees ``sine`` g."""
    return int(np.clip(round(od.ACCEL_ZERO + od.ACCEL_SCALE * sine), 0, 2047))


@dataclass
class _Segment:
    """One queued joint move: target, speed fraction and pause after it (s)."""

    goal: np.ndarray
    speed: float
    pause: float
    queued_at: float
    linear: bool = False


class DobotV1Emulator(PtyEmulator):
    """The original Dobot V1.0 firmware behind a pseudo-terminal.

    ``status_period`` (s) is the status stream's period (50 ms assumed: the
    firmware's is unconfirmed, the 2015 prototype used 60 ms); ``fifo_depth``
    the number of queued moves it keeps (unconfirmed; extra moves are dropped);
    ``boot_time`` (s) how long a reset keeps it silent (see the module docstring).
    Angles are degrees, positions mm.
    """

    def __init__(
        self,
        model: DobotV1Model,
        clock: Clock,
        *,
        seed: int = 0,
        q0: np.ndarray | None = None,
        status_period: float = 0.05,
        fifo_depth: int = 4,
        boot_time: float = BOOT_TIME,
    ) -> None:
        super().__init__(model, clock, seed=seed, q0=q0)
        self.status_period = status_period
        self.fifo_depth = fifo_depth
        self.boot_time = boot_time
        #: Resets since power-up (opens of the port after the first).
        self.reboots = 0
        #: Commands dropped because they came faster than one per status frame.
        self.dropped = 0
        #: Commands refused (unreachable state-3 targets, unknown states).
        self.refused = 0
        self._power_up_settings()
        self._booted_at = -math.inf
        self._fifo: collections.deque[_Segment] = collections.deque()
        self._busy_until = -math.inf
        self._next_status = math.inf
        self._accepted_since_status = False
        self._parser = codec.frame_parser()

    # ------------------------------------------------------------------ firmware

    def on_start(self) -> None:
        """Power-up: the first status frame goes out at once (Dobot protocol, status frame)."""
        self._next_status = self.time

    def on_port_opened(self, t: float) -> None:
        """The port was opened: the first open finds the board booted, later ones reset it."""
        if self.port_opens > 1:
            self.reboot(t)

    def reboot(self, t: float) -> None:
        """Reset the board at ``t`` (s): silent for :attr:`boot_time`, then the pose re-read.

        The steppers stop where they are, queued moves, suction, gripper and
        motion settings are lost, and the believed joints become
        :func:`accelerometer_pose` of the true ones (the base's belief 0, its
        true angle unchanged). Status frames resume at ``t + boot_time``.
        """
        self.reboots += 1
        self._fifo.clear()
        self._busy_until = -math.inf
        self.joints.rereference(accelerometer_pose(self.joints.true(t)), t)
        self.joints.max_speed[:] = [j.max_speed for j in self.model.joints]
        self.joints.max_accel[:] = [j.max_accel for j in self.model.joints]
        self._power_up_settings()
        self._parser.reset()
        self._accepted_since_status = False
        self._booted_at = t + self.boot_time
        self._next_status = self._booted_at

    def _power_up_settings(self) -> None:
        """Tool and motion settings as the board boots with them."""
        self.suction = False
        self.gripper = 0.0
        self.r_head = 0.0
        self.speed_ratio = DEFAULT_SPEED_RATIO
        self.jump_height = DEFAULT_JUMP_HEIGHT
        #: Linear (MOVL) maxima, mm/s and mm/s^2 (state 9 sub-mode 1, F7 and F8).
        self.linear_speed = DEFAULT_LINEAR_SPEED
        self.linear_accel = DEFAULT_LINEAR_ACCEL

    def tool(self) -> ToolState:
        """Suction pump and gripper as the firmware drives them."""
        return ToolState(suction=self.suction, gripper=self.gripper)

    def halt(self, reason: str) -> None:
        """Stop dead and forget queued moves."""
        with self._lock:
            self._fifo.clear()
            self._busy_until = -math.inf
        super().halt(reason)

    def next_event_time(self) -> float | None:
        """The next status frame, or the end of the current move if sooner."""
        if self._fifo and self._busy_until < self._next_status:
            return max(self._busy_until, self.time)
        return self._next_status

    def on_timer(self, t: float) -> None:
        """Start queued moves whose turn has come and send the status frames due."""
        self._start_due_moves(t)
        while self._next_status <= t + 1e-12:
            ts = self._next_status
            self._start_due_moves(ts)
            self.send(self._status(ts).encode())
            self._accepted_since_status = False
            self._next_status = ts + self.status_period

    def on_bytes(self, data: bytes, t: float) -> None:
        """Handle host frames; one command per status interval is accepted.

        Bytes that arrive while the board boots are lost.
        """
        if t < self._booted_at:
            return
        for frame in self._parser.feed(data):
            if self._accepted_since_status:
                self.dropped += 1
                continue
            self._accepted_since_status = True
            self._command(codec.Command.decode(frame), t)

    # ------------------------------------------------------------------ internals

    def _status(self, t: float) -> codec.Status:
        q = self.joints.reported(t)
        x, y, z = self.model.position(q)
        return codec.Status(
            x, y, z, self.r_head, q[0], q[1], q[2], self.r_head, float(self.suction), self.gripper
        )

    def _start_due_moves(self, t: float) -> None:
        while self._fifo and self._busy_until <= t + 1e-12:
            seg = self._fifo.popleft()
            # A queued move starts when the previous one ended, or when it arrived.
            start = max(self._busy_until, seg.queued_at)
            if seg.linear:
                move = self.joints.start(
                    LineMove(
                        self._line_ik,
                        self.joints.reported(start),
                        seg.goal,
                        self.model.position,
                        start,
                        self.linear_speed,
                        self.linear_accel,
                        seg.speed,
                    )
                )
            else:
                move = self.joints.move_to(seg.goal, start, seg.speed)
            self._busy_until = move.end_time + seg.pause

    def _line_ik(self, xyz: np.ndarray) -> np.ndarray:
        sols = self.model.ik_all(xyz)
        ok = np.all(np.isfinite(sols), axis=-1)
        return sols[np.argmax(ok)] if np.any(ok) else np.full(3, np.nan)

    def _enqueue(self, goal: np.ndarray, pause: float, t: float, linear: bool = False) -> None:
        if len(self._fifo) >= self.fifo_depth:
            self.dropped += 1
            return
        goal = np.clip(goal, HARDWARE_LOWER, HARDWARE_UPPER)
        self._fifo.append(_Segment(goal, self.speed_ratio, max(0.0, pause), t, linear))
        self._start_due_moves(t)

    def _command(self, cmd: codec.Command, t: float) -> None:
        fields = (
            cmd.state,
            cmd.axis,
            cmd.r_head,
            cmd.is_grab,
            cmd.start_vel,
            cmd.end_vel,
            cmd.max_vel,
        )
        if not all(math.isfinite(v) and abs(v) <= 1e6 for v in fields):
            # garbage the firmware cannot act on (a corrupted frame): ignored
            self.refused += 1
            return
        state = int(round(cmd.state))
        values = np.array([cmd.x, cmd.y, cmd.z], dtype=float)
        if state in (codec.STATE_MOVE_JOINTS, codec.STATE_MOVE_XYZ):
            if not np.all(np.isfinite(values)):
                self.refused += 1
                return
            if state == codec.STATE_MOVE_XYZ:
                try:
                    values = self.model.ik(values, near=self.joints.reported(t))
                except Unreachable:
                    # the real firmware loses control here (open-dobot issue #32); refuse instead
                    self.refused += 1
                    return
            self.suction = cmd.is_grab != 0.0
            self.r_head = float(cmd.r_head)
            self.gripper = float(cmd.end_vel)
            mode = int(round(cmd.start_vel))
            if mode == codec.MODE_JUMP:
                self._enqueue_jump(values, cmd.max_vel, t)
            else:
                self._enqueue(values, cmd.max_vel, t, linear=mode == codec.MODE_MOVL)
        elif state in (codec.STATE_JOINT_JOG, codec.STATE_LINEAR_JOG):
            self._jog(int(round(cmd.axis)), cmd.start_vel, t)
        elif state == codec.STATE_CONFIG:
            if int(round(cmd.axis)) == codec.CONFIG_PLAYBACK:
                if math.isfinite(cmd.x) and 0 < cmd.x <= 1e4:
                    self.joints.max_speed[:] = cmd.x
                if math.isfinite(cmd.y) and 0 < cmd.y <= 1e5:
                    self.joints.max_accel[:] = cmd.y
                if 0 < cmd.is_grab <= 1e4:  # F7: max linear speed
                    self.linear_speed = float(cmd.is_grab)
                if 0 < cmd.start_vel <= 1e5:  # F8: max linear acceleration
                    self.linear_accel = float(cmd.start_vel)
                if 0 < cmd.max_vel <= 200:
                    self.jump_height = float(cmd.max_vel)
        elif state == codec.STATE_SPEED:
            if math.isfinite(cmd.x):
                self.speed_ratio = float(np.clip(cmd.x / 100.0, 0.01, 1.0))
        else:
            self.refused += 1

    def _enqueue_jump(self, goal: np.ndarray, pause: float, t: float) -> None:
        """JUMP: lift by the jump height, cross over, lower (Dobot protocol, move modes)."""
        here = self.model.position(self.joints.reported(t))
        there = self.model.position(goal)
        lift = np.array([0.0, 0.0, self.jump_height])
        try:
            up = self.model.ik(here + lift, near=self.joints.reported(t))
            over = self.model.ik(there + lift, near=goal)
        except Unreachable:
            self._enqueue(goal, pause, t)
            return
        # vertical legs are straight lines, the crossing a joint move (Dobot protocol, move modes)
        for q, p, linear in ((up, 0.0, True), (over, 0.0, False), (goal, pause, True)):
            self._enqueue(q, p, t, linear)

    def _jog(self, axis: int, speed_percent: float, t: float) -> None:
        if axis == codec.AXIS_STOP:
            self._fifo.clear()
            self.joints.brake(t)
            self._busy_until = max(t, self.joints.end_time)
        elif axis == codec.AXIS_GRAB:
            self.suction = True
        elif axis == codec.AXIS_RELEASE:
            self.suction = False
        elif 1 <= axis <= 6:
            joint = (axis - 1) // 2
            goal = self.joints.reported(t)
            goal[joint] = HARDWARE_UPPER[joint] if axis % 2 == 1 else HARDWARE_LOWER[joint]
            self._fifo.clear()
            speed = float(np.clip(speed_percent / 100.0, 0.01, 1.0))
            move = self.joints.move_to(goal, t, speed)
            self._busy_until = move.end_time
