"""Driver for a DH arm on an SSC-32 servo board (one hobby servo per joint).

Joint targets are checked against the model's limits (and the range each
servo reaches, which the model's limits already include) before a byte is
sent, turned into pulses through each joint's fitted servo map (seed 001) and
sent as one group move timed so that no joint exceeds its speed. The board
gives no acknowledgement, so the driver polls it: ``QP`` reads back every
pulse (10 us resolution) and ``Q`` says whether the move is finished; a move
is DONE when the board reports ``.`` for a query sent after the move. A
reply that does not come within ``reply_timeout`` is retried, and after
``retries`` silent polls the link counts as lost. Units: degrees / mm.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from armtree.errors import HardwareFault, Unreachable
from armtree.plugins.arms.common.serial_driver import SerialArmDriver
from armtree.rig import MotionHandle, MotionStatus, ToolState

from . import ssc32 as S
from .kinematics import DHModel


@dataclass
class _Move:
    handle: MotionHandle
    seq: int
    goal: np.ndarray
    start: np.ndarray


class SSC32Driver(SerialArmDriver):
    """A DH arm whose joints are servos on an SSC-32 (115200 8N1 by default)."""

    protocol = "an SSC-32 servo controller (VER -> SSC32-...)"

    def __init__(
        self,
        model: DHModel,
        port: str,
        servos: Sequence[S.ServoMap],
        *,
        gripper: S.ServoMap | None = None,
        suction_channel: int | None = None,
        poll_period: float = 0.02,
        reply_timeout: float = 0.3,
        retries: int = 3,
        **options,
    ) -> None:
        options.setdefault("baud", 115200)
        super().__init__(model, port, **options)
        self.model: DHModel = model
        self.servos = list(servos)
        self.gripper_map = gripper
        self.suction_channel = suction_channel
        self.poll_period = poll_period
        self.reply_timeout = reply_timeout
        self.retries = retries
        self.version = ""
        self._lock = threading.RLock()
        self._buf = bytearray()
        self._expect = 0  # bytes the outstanding query will return (0: none outstanding)
        self._query_seq = 0
        self._query_sent = -math.inf
        self._silent_polls = 0
        self._next_poll = -math.inf
        self._move_seq = 0
        self._moves: list[_Move] = []
        self._pulses: np.ndarray | None = None
        self._commanded: np.ndarray | None = None
        self._commanded_pulses: np.ndarray | None = None
        self._tool = ToolState()
        self._last_handle: MotionHandle | None = None
        #: Wall time (``time.perf_counter``) of the newest joint report, for latency figures.
        self.status_wall = 0.0

    # ------------------------------------------------------------------ serial hooks

    def on_open(self) -> None:
        """Ask for the firmware version (the handshake)."""
        with self._lock:
            self._buf.clear()
            self.version = ""
            self._expect = 0
        self.write(b"VER\r")

    def handshake_done(self) -> bool:
        """True once the board printed an SSC-32 version."""
        return self.version.upper().startswith("SSC32")

    def on_data(self, data: bytes) -> None:
        """Version text before the handshake, then fixed-length query replies."""
        with self._lock:
            self._buf.extend(data)
            if not self.handshake_done():
                end = self._buf.find(b"\r")
                if end >= 0:
                    text = self._buf[:end].decode("ascii", "replace").strip()
                    del self._buf[: end + 1]
                    if text.upper().startswith("SSC32"):
                        self.version = text
                        self.mark_alive()
                elif len(self._buf) > 64:
                    del self._buf[:-64]
                return
            if not self._expect:
                self._buf.clear()  # nothing asked: the board never talks unasked, so it is noise
                return
            if len(self._buf) >= self._expect:
                reply = bytes(self._buf[: self._expect])
                del self._buf[: self._expect]
                self._expect = 0
                self._on_reply(reply)

    def _on_reply(self, reply: bytes) -> None:
        status = reply[-1:]
        if status not in (b"+", b"."):
            self._buf.clear()  # out of step with the board: drop and ask again
            return
        self.mark_alive()
        self._silent_polls = 0
        pulses = np.array([10.0 * b for b in reply[:-1]])
        self._pulses = pulses
        self.status_wall = time.perf_counter()
        finished = status == b"."
        moves = list(self._moves)
        done = []
        joints = self.joints()
        for m in moves:
            if m.handle.done:
                done.append(m)
            elif finished and self._query_seq > m.seq:
                m.handle.update(MotionStatus.DONE)
                done.append(m)
            else:
                total = np.linalg.norm(m.goal - m.start)
                left = np.linalg.norm(m.goal - joints)
                m.handle.update(MotionStatus.RUNNING, progress=1 - left / total if total else 0)
        self._moves = [m for m in self._moves if m not in done]

    def on_time(self, now: float) -> None:
        """Poll pulses and motion status; retry a lost reply; give up after ``retries``."""
        with self._lock:
            if not self.handshake_done():
                return
            fail = False
            if self._expect and now - self._query_sent > self.reply_timeout:
                self._silent_polls += 1
                self._expect = 0
                self._buf.clear()
                fail = self._silent_polls > self.retries
            send = not self._expect and now >= self._next_poll
            if send:
                self._next_poll = now + self.poll_period
                channels = [m.channel for m in self.servos]
                self._expect = len(channels) + 1
                self._buf.clear()
                self._query_sent = now
                self._query_seq = self._move_seq + 1
        if fail:
            self.lose_link(f"link lost: the SSC-32 did not answer {self.retries + 1} queries")
            return
        if send:
            self.write(S.query_pulses(channels)[:-1] + b" Q\r")

    # ------------------------------------------------------------------ ArmDriver

    def joints(self) -> np.ndarray:
        """Joint values from the read-back pulses, degrees / mm.

        ``QP`` reads pulses in 10 us steps (about 1 degree on a standard
        servo); where the read-back agrees with the commanded pulse to within
        that step, the commanded pulse is the better figure and is used.
        """
        if self._pulses is None:
            return self.model.home.copy() if self._commanded is None else self._commanded.copy()
        pulses = self._pulses
        if self._commanded_pulses is not None:
            close = np.abs(pulses - self._commanded_pulses) <= 5.0
            pulses = np.where(close, self._commanded_pulses, pulses)
        return np.array([float(m.angle(p)) for m, p in zip(self.servos, pulses, strict=True)])

    @property
    def tool(self) -> ToolState:
        """Pump and gripper as last commanded."""
        return self._tool

    def move_joints(self, q: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Group move of every joint servo to ``q``, timed by the slowest joint at ``speed``."""
        description = f"move joints {np.round(np.asarray(q, dtype=float), 2).tolist()}"
        try:
            goal = self.checked_joints(q)
            pulses = {
                m.channel: int(round(float(m.pulse(v))))
                for m, v in zip(self.servos, goal, strict=True)
            }
            bad = {ch: p for ch, p in pulses.items() if not S.PULSE_MIN <= p <= S.PULSE_MAX}
            if bad:
                raise Unreachable(
                    f"{self.model.name}: joint target {np.round(goal, 2).tolist()} "
                    f"needs pulses {bad} outside {S.PULSE_MIN}-{S.PULSE_MAX} us"
                )
        except Unreachable as exc:
            return self.refused(description, exc)
        fault = self.ensure_connected()
        if fault is not None:
            return self.refused(description, fault)
        key = ("move", tuple(sorted(pulses.items())), round(float(speed), 3))
        if self.is_duplicate(key) and self._last_handle is not None and not self._last_handle.done:
            return self._last_handle
        start = self.joints()
        vmax = np.array([j.max_speed for j in self.model.joints]) * float(
            min(max(speed, 0.01), 1.0)
        )
        time_ms = int(math.ceil(1000.0 * float(np.max(np.abs(goal - start) / vmax))))
        handle = self.track(MotionHandle(description, goal))
        with self._lock:
            self._move_seq += 1
            self._moves.append(_Move(handle, self._move_seq, goal, start))
            self._commanded = goal
            self._commanded_pulses = np.array([float(pulses[m.channel]) for m in self.servos])
        if not self.write(S.move_command(pulses, max(time_ms, 1))):
            handle.update(
                MotionStatus.FAILED, error=self.fault or HardwareFault("not sent", self.device)
            )
        else:
            handle.update(MotionStatus.RUNNING, progress=0.0)
        self.remember_sent(key)
        self._last_handle = handle
        return handle

    def set_gripper(self, opening: float) -> MotionHandle:
        """Gripper servo to ``opening`` (degrees through its map), if the profile has one."""
        if self.gripper_map is None:
            return super().set_gripper(opening)
        pulse = int(round(float(self.gripper_map.pulse(opening))))
        if not S.PULSE_MIN <= pulse <= S.PULSE_MAX:
            return self.refused(
                "gripper",
                Unreachable(f"{self.model.name}: gripper opening {opening} needs pulse {pulse} us"),
            )
        fault = self.ensure_connected()
        if fault is not None:
            return self.refused("gripper", fault)
        handle = self.track(MotionHandle(f"gripper {opening:g}"))
        with self._lock:
            self._move_seq += 1
            self._moves.append(_Move(handle, self._move_seq, self.joints(), self.joints()))
        self.write(S.move_command({self.gripper_map.channel: pulse}, 300))
        self._tool = ToolState(suction=self._tool.suction, gripper=float(opening))
        self.remember_sent(None)
        return handle

    def set_suction(self, on: bool) -> MotionHandle:
        """Pump on a digital output (``#<ch>H`` / ``#<ch>L``), if the profile names one."""
        handle = MotionHandle(f"suction {'on' if on else 'off'}")
        if self.suction_channel is None:
            handle.update(
                MotionStatus.FAILED,
                error=HardwareFault(
                    "this arm has no suction pump (set arm.suction_channel)", self.device
                ),
            )
            return handle
        fault = self.ensure_connected()
        if fault is not None:
            return self.refused(handle.description, fault)
        level = "H" if on else "L"
        if self.write(f"#{self.suction_channel}{level}\r".encode("ascii")):
            self._tool = ToolState(suction=bool(on), gripper=self._tool.gripper)
            handle.update(MotionStatus.DONE)
        else:
            handle.update(MotionStatus.FAILED, error=self.fault)
        self.remember_sent(None)
        return handle

    def stop(self) -> None:
        """``STOP`` every joint channel at once: the servos hold where they are."""
        with self._lock:
            self._moves.clear()
            self._commanded_pulses = None  # stopped mid-ramp: only the read-back is known
        self.stop_all()
        self.remember_sent(None)
        self._last_handle = None
        if self._ser is not None:
            self.write(S.stop_command([m.channel for m in self.servos]))
