"""An SSC-32 servo controller driving a DH arm's hobby servos, behind a pseudo-terminal.

Follows the Lynxmotion SSC-32 manual (see ``ssc32``): commands end with a
carriage return; a group move takes every listed channel from its pulse to
the new one linearly so that they all arrive together, after ``T`` ms, at the
``S`` speeds (us per second), or as fast as the servos turn; ``Q`` answers
``+`` while moving and ``.`` when done; ``QP<ch>`` one byte, pulse / 10;
``#<ch>H`` / ``#<ch>L`` drive a channel as a digital output (a pump);
``STOP<ch>`` freezes a channel; ``VER`` prints the version. Nothing else is
ever answered. Joint angles come from the pulses through each joint's servo
map (Aceves slides). Units: degrees / mm, microseconds, seconds on the run's clock.

A hobby servo holds its position with its own feedback loop, so a slip (the
``missed_steps`` fault: a load or a knock turning the horn) does not pile up as
a stepper's lost steps do: the joint stays off by it until the servo is next
commanded, and then moves from where it really is to the new target.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from armtree.api.clock import Clock
from armtree.api.rig import ToolState
from armtree.plugins.arms.common.pty_emulator import PtyEmulator

from . import ssc32 as S
from .kinematics import DHModel

#: Channels on the board.
CHANNELS = 32
#: Physical servo speed when a move gives neither T nor S: 60 degrees in 0.17 s.
SERVO_SPEED_DEG = 60.0 / 0.17


class SSC32Emulator(PtyEmulator):
    """The SSC-32 board and the servos of a DH arm (one servo per joint).

    ``servos`` maps each joint to its channel and pulse-to-angle line;
    ``gripper`` optionally maps a gripper servo (opening in degrees);
    ``suction_channel`` is a digital output driving a pump.
    """

    def __init__(
        self,
        model: DHModel,
        clock: Clock,
        servos: Sequence[S.ServoMap],
        *,
        gripper: S.ServoMap | None = None,
        suction_channel: int | None = None,
        seed: int = 0,
        q0: np.ndarray | None = None,
    ) -> None:
        super().__init__(model, clock, seed=seed, q0=q0)
        self.servos = list(servos)
        self.gripper_map = gripper
        self.suction_channel = suction_channel
        q = np.asarray(model.home if q0 is None else q0, dtype=float)
        self._p0 = np.full(CHANNELS, 1500.0)
        for m, v in zip(self.servos, q, strict=True):
            self._p0[m.channel] = float(np.clip(m.pulse(v), S.PULSE_MIN, S.PULSE_MAX))
        self._p1 = self._p0.copy()
        self._t0 = np.zeros(CHANNELS)
        self._t1 = np.zeros(CHANNELS)
        #: The newest ``(t, pulses)`` worked out: a tick asks for the same instant's pulses
        #: several times (a query, the world's joints, the gripper).
        self._pulses_at: tuple[float, np.ndarray] | None = None
        self._outputs: dict[int, bool] = {}
        self._buf = bytearray()
        self._joint_servos = S.JointServos(self.servos)

    # ------------------------------------------------------------------ pulses in time

    def pulses(self, t: float) -> np.ndarray:
        """Every channel's pulse width at ``t`` (microseconds; read-only)."""
        cached = self._pulses_at
        if cached is not None and cached[0] == t:
            return cached[1]
        span = np.maximum(self._t1 - self._t0, 1e-12)
        s = np.minimum(np.maximum((t - self._t0) / span, 0.0), 1.0)
        s = np.where(self._t1 <= self._t0, 1.0, s)
        pulses = self._p0 + (self._p1 - self._p0) * s
        pulses.flags.writeable = False
        self._pulses_at = (t, pulses)
        return pulses

    def _angles(self, t: float) -> np.ndarray:
        return self._joint_servos.angles(self.pulses(t)[self._joint_servos.channels])

    def true_joints(self) -> np.ndarray:
        """Joint angles from the servo pulses (plus any injected slip), degrees / mm."""
        with self._lock:
            return self._angles(self.time) + self.joints.missed

    def reported_joints(self) -> np.ndarray:
        """Joint angles the pulses command (the board has no feedback)."""
        with self._lock:
            return self._angles(self.time)

    def moving(self, t: float) -> bool:
        """True while any channel is still ramping at ``t``."""
        return bool(np.any(self._t1 > t))

    def tool(self) -> ToolState:
        """Pump output and gripper servo opening (degrees)."""
        suction = bool(self.suction_channel is not None and self._outputs.get(self.suction_channel))
        grip = None
        if self.gripper_map is not None:
            with self._lock:  # as true_joints: a step on another thread may be moving it
                grip = float(
                    self.gripper_map.angle(self.pulses(self.time)[self.gripper_map.channel])
                )
        return ToolState(suction=suction, gripper=grip)

    def halt(self, reason: str) -> None:
        """Freeze every channel where it is."""
        with self._lock:
            self._freeze(range(CHANNELS), self.time)
            self.halted_reason = reason

    # ------------------------------------------------------------------ PtyEmulator hooks

    def on_bytes(self, data: bytes, t: float) -> None:
        """Run every complete command line (carriage return); ESC cancels the line."""
        for byte in data:
            if byte == 0x1B:
                self._buf.clear()
            elif byte == 0x0D:
                self._command(self._buf.decode("ascii", "replace"), t)
                self._buf.clear()
            elif byte != 0x0A and len(self._buf) < 256:
                self._buf.append(byte)

    def _freeze(self, channels, t: float) -> None:
        now = self.pulses(t)
        self._pulses_at = None
        for ch in channels:
            self._p0[ch] = self._p1[ch] = now[ch]
            self._t0[ch] = self._t1[ch] = t

    def _command(self, line: str, t: float) -> None:
        req = S.parse_request(line)
        compact = line.upper().replace(" ", "")
        if "H" in compact or "L" in compact:  # most lines (moves, queries) set no output
            for ch in range(CHANNELS):
                if f"#{ch}H" in compact:
                    self._outputs[ch] = True
                elif f"#{ch}L" in compact:
                    self._outputs[ch] = False
        if req.stops:
            self._freeze([c for c in req.stops if 0 <= c < CHANNELS], t)
        if req.moves:
            self._group_move(req, t)
        out = bytearray()
        pulses = None
        for kind, channel in req.queries:
            if kind == "Q":
                out += b"+" if self.moving(t) else b"."
            elif channel is not None and 0 <= channel < CHANNELS:
                pulses = self.pulses(t).tolist() if pulses is None else pulses
                out.append(int(round(pulses[channel] / 10.0)) & 0xFF)
        if req.version:
            out += (S.VERSION + "\r").encode("ascii")
        if out:
            self.send(bytes(out))

    def _group_move(self, req: S.Request, t: float) -> None:
        now = self.pulses(t).copy()
        self._pulses_at = None
        # a commanded servo starts from where it really is: its slip is taken up by the move
        for j, m in enumerate(self.servos):
            if m.channel in req.moves and self.joints.missed[j]:
                now[m.channel] += self.joints.missed[j] / m.slope
                self.joints.missed[j] = 0.0
        targets = {
            ch: float(min(max(p, S.PULSE_MIN), S.PULSE_MAX))
            for ch, (p, _) in req.moves.items()
            if 0 <= ch < CHANNELS
        }
        duration = 0.0 if req.time_ms is None else req.time_ms / 1000.0
        slopes = {m.channel: abs(m.slope) for m in self.servos}
        if self.gripper_map is not None:
            slopes[self.gripper_map.channel] = abs(self.gripper_map.slope)
        for ch, target in targets.items():
            delta = abs(target - now[ch])
            speed = req.moves[ch][1]
            if speed:
                duration = max(duration, delta / speed)
            # a servo cannot turn faster than it does: the group waits for the slowest
            duration = max(duration, delta * slopes.get(ch, 0.09) / SERVO_SPEED_DEG)
        for ch, target in targets.items():
            self._p0[ch], self._p1[ch] = now[ch], target
            self._t0[ch], self._t1[ch] = t, t + duration

    def next_event_time(self) -> float | None:
        """The end of the current ramp (so ``Q`` turns to ``.`` on time)."""
        pending = self._t1[self._t1 > self.time]
        return float(pending.min()) if pending.size else None
