"""Driver for a DH arm on an SSC-32 servo board (one hobby servo per joint).

Joint targets are checked against the model's limits (and the range each
servo reaches, which the model's limits already include) before a byte is
sent and turned into pulses through each joint's fitted servo map (Aceves slides).
The board only ramps each servo linearly to a target, so the driver times the
motion itself: a target, or a planner's whole path (:meth:`SSC32Driver.follow_path`),
becomes a cubic or quintic trajectory within the joints' speed and
acceleration limits (Pozzani 2023, eq. 2), is validated along the way (limits,
speeds, collisions with the profile's scene, the arm with itself) and only
then streamed as short timed group moves (:mod:`.streaming`); a trajectory
that fails is refused with the reason and nothing is sent. With
``trajectory: none`` a target is one group move timed by the slowest joint.
The board gives no acknowledgement, so the driver polls it: ``QP`` reads back every
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

from armtree.api.rig import MotionHandle, MotionStatus, ToolState
from armtree.errors import HardwareFault, PlanningError, Unreachable
from armtree.maths.motion.collision import CollisionChecker
from armtree.maths.motion.scene import Scene
from armtree.maths.motion.trajectory import Trajectory
from armtree.plugins.arms.common.plausibility import StatusGuard
from armtree.plugins.arms.common.serial_driver import SerialArmDriver
from armtree.plugins.arms.common.streaming import TrajectoryStream, timed_path

from . import ssc32 as S
from .kinematics import DHModel

#: Ways the driver times a motion (``arm.trajectory``).
TRAJECTORY_KINDS = ("cubic", "quintic", "none")


@dataclass
class _Move:
    handle: MotionHandle
    seq: int
    goal: np.ndarray
    start: np.ndarray


@dataclass
class _Stream:
    handle: MotionHandle
    stream: TrajectoryStream
    start: np.ndarray


class SSC32Driver(SerialArmDriver):
    """A DH arm whose joints are servos on an SSC-32 (115200 8N1 by default).

    ``trajectory`` is ``"cubic"`` (Pozzani 2023, eq. 2), ``"quintic"`` or
    ``"none"``; ``stream_period`` (s) is the time between streamed set points;
    ``checker`` validates trajectories against the profile's obstacles
    (without one, against the arm itself only). ``tool`` is ``"suction"`` (a
    pump on ``suction_channel``) or ``"gripper"`` (the default when there is a
    gripper and no pump): then :meth:`set_suction` closes the gripper to
    ``grip_angles[0]`` and opens it to ``grip_angles[1]`` degrees.
    """

    protocol = "an SSC-32 servo controller (VER -> SSC32-...)"

    def __init__(
        self,
        model: DHModel,
        port: str,
        servos: Sequence[S.ServoMap],
        *,
        gripper: S.ServoMap | None = None,
        suction_channel: int | None = None,
        tool: str | None = None,
        grip_angles: tuple[float, float] = (0.0, 90.0),
        poll_period: float = 0.02,
        reply_timeout: float = 0.3,
        retries: int = 3,
        trajectory: str = "cubic",
        stream_period: float = 0.05,
        checker: CollisionChecker | None = None,
        **options,
    ) -> None:
        options.setdefault("baud", 115200)
        super().__init__(model, port, **options)
        self.model: DHModel = model
        self.servos = list(servos)
        self._joint_servos = S.JointServos(self.servos)
        #: Doubts the joint values read back from the board (finite, limits, speed).
        self.guard = StatusGuard(model)
        self.gripper_map = gripper
        self.suction_channel = suction_channel
        self.tool_kind = tool or ("gripper" if suction_channel is None and gripper else "suction")
        self.grip_closed, self.grip_open = (float(a) for a in grip_angles)
        self.poll_period = poll_period
        self.reply_timeout = reply_timeout
        self.retries = retries
        if trajectory not in TRAJECTORY_KINDS:
            raise ValueError(f"trajectory must be one of {TRAJECTORY_KINDS}, got {trajectory!r}")
        self.trajectory_kind = trajectory
        self.interpolates = trajectory == "none"
        self.stream_period = float(stream_period)
        self.checker = checker or CollisionChecker(model, Scene())
        #: The newest trajectory followed and its start on the run clock (s), for tests and plots.
        self.last_trajectory: tuple[float, Trajectory] | None = None
        self._stream: _Stream | None = None
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
        self._gripper_readback: float | None = None
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
            self.guard.refused(f"a query reply ending in {status!r}, not + or .")
            return
        pulses = np.array([10.0 * b for b in reply[:-1]])
        joint_pulses = pulses[:-1] if self.gripper_map is not None else pulses
        q = self._joint_servos.angles(joint_pulses)
        if self.guard.check(q, self._now if math.isfinite(self._now) else 0.0) is not None:
            return
        self.mark_alive()
        self._silent_polls = 0
        if self.gripper_map is not None:
            # the gripper's channel is read last: where it is until the host commands it
            self._gripper_readback = float(self.gripper_map.angle(pulses[-1]))
            pulses = pulses[:-1]
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
                total = float(np.linalg.norm(m.goal - m.start))
                left = float(np.linalg.norm(m.goal - joints))
                m.handle.update(MotionStatus.RUNNING, progress=1 - left / total if total else 0)
        self._moves = [m for m in self._moves if m not in done]

    def on_time(self, now: float) -> None:
        """Send the set point due, poll pulses and motion status; retry a lost reply;
        give up after ``retries``."""
        with self._lock:
            if not self.handshake_done():
                return
            command = self._stream_step(now)
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
                if self.gripper_map is not None:
                    channels.append(self.gripper_map.channel)
                self._expect = len(channels) + 1
                self._buf.clear()
                self._query_sent = now
                self._query_seq = self._move_seq + 1
        query = S.query_pulses(channels)[:-1] + b" Q\r" if send and not fail else b""
        if command or query:
            # the set point and the query in one write: the same bytes, one system call
            self.write(command + query)
        if fail:
            self.lose_link(f"link lost: the SSC-32 did not answer {self.retries + 1} queries")

    def _stream_step(self, now: float) -> bytes:
        """The group move of the set point due at ``now`` (empty when none is); lock held."""
        active = self._stream
        if active is None or not active.stream.due(now):
            if active is not None:
                active.handle.update(MotionStatus.RUNNING, progress=active.stream.progress(now))
            return b""
        point = active.stream.next(now)
        pulses = self._pulses_for(point.q)
        ramp_ms = max(1, int(round(1000.0 * point.ramp_s)))
        if point.last:
            # from here on the board's Q says when the servos are there
            self._stream = None
            self._move_seq += 1
            self._moves.append(_Move(active.handle, self._move_seq, point.q, active.start))
            self._commanded = point.q
            self._commanded_pulses = np.array([float(pulses[m.channel]) for m in self.servos])
        else:
            active.handle.update(MotionStatus.RUNNING, progress=active.stream.progress(now))
        return S.move_command(pulses, ramp_ms)

    def _pulses_for(self, q: np.ndarray) -> dict[int, int]:
        """Each joint servo's pulse (us, whole) for joints ``q``, kept on the board's range."""
        pulses = self._joint_servos.pulses(q)
        return {
            m.channel: min(max(round(p), S.PULSE_MIN), S.PULSE_MAX)
            for m, p in zip(self.servos, pulses.tolist(), strict=True)
        }

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
        return self._joint_servos.angles(pulses)

    @property
    def tool(self) -> ToolState:
        """Pump and gripper as last commanded; before the gripper is commanded, its
        opening as the board reads it back (degrees)."""
        if self._tool.gripper is None and self._gripper_readback is not None:
            return ToolState(suction=self._tool.suction, gripper=self._gripper_readback)
        return self._tool

    def move_joints(self, q: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Move every joint servo to ``q``: along a timed trajectory (:meth:`follow_path`),
        or with ``trajectory: none`` as one group move timed by the slowest joint at ``speed``."""
        if not self.interpolates:
            return self.follow_path(np.atleast_2d(np.asarray(q, dtype=float)), speed)
        description = f"move joints {np.round(np.asarray(q, dtype=float), 2).tolist()}"
        try:
            goal, pulses = self._checked_goal(q)
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

    def follow_path(self, waypoints: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Follow joint ``waypoints`` ``(N, n)`` from where the arm is, without stopping between them.

        The path is timed as a ``trajectory`` (cubic or quintic) within the
        joints' speed and acceleration limits scaled by ``speed`` (0 to 1),
        validated along the way (limits, speeds, collisions) and streamed. A
        refused waypoint or trajectory gives a FAILED handle naming why
        (:class:`Unreachable` or :class:`PlanningError`); nothing is sent.
        """
        points = np.atleast_2d(np.asarray(waypoints, dtype=float))
        description = f"follow path to {np.round(points[-1], 2).tolist()}"
        try:
            checked = [self._checked_goal(w)[0] for w in points]
        except Unreachable as exc:
            return self.refused(description, exc)
        fault = self.ensure_connected()
        if fault is not None:
            return self.refused(description, fault)
        goal_pulses = self._pulses_for(checked[-1])
        key = ("path", tuple(sorted(goal_pulses.items())), round(float(speed), 3))
        if self.is_duplicate(key) and self._last_handle is not None and not self._last_handle.done:
            return self._last_handle
        start = self.joints()
        try:
            trajectory = self.time_path(np.vstack([start, *checked]), speed)
        except PlanningError as exc:
            return self.refused(description, exc)
        handle = self.track(MotionHandle(description, checked[-1]))
        now = self.clock.now() if self.barrier is None else self._current_time()
        with self._lock:
            if self._stream is not None:
                self._stream.handle.update(MotionStatus.STOPPED)
            self._stream = _Stream(
                handle, TrajectoryStream(trajectory, now, self.stream_period), start
            )
            self._commanded = None
            self._commanded_pulses = None  # moving: only the read-back is known
            command = self._stream_step(now)
        self.last_trajectory = (now, trajectory)
        if not self.write(command):
            handle.update(
                MotionStatus.FAILED, error=self.fault or HardwareFault("not sent", self.device)
            )
            with self._lock:
                self._stream = None
        else:
            handle.update(MotionStatus.RUNNING, progress=0.0)
        self.remember_sent(key)
        self._last_handle = handle
        return handle

    def time_path(self, path: np.ndarray, speed: float = 1.0) -> Trajectory:
        """The validated trajectory through joint configurations ``path`` ``(N, n)``
        (:func:`~armtree.plugins.arms.common.streaming.timed_path`)."""
        return timed_path(path, self.trajectory_kind, self.checker, speed)

    def _checked_goal(self, q: np.ndarray) -> tuple[np.ndarray, dict[int, int]]:
        """``q`` within the limits and its pulses within the board's range; raises Unreachable."""
        goal = self.checked_joints(q)
        pulses = {
            m.channel: int(round(float(m.pulse(v)))) for m, v in zip(self.servos, goal, strict=True)
        }
        bad = {ch: p for ch, p in pulses.items() if not S.PULSE_MIN <= p <= S.PULSE_MAX}
        if bad:
            raise Unreachable(
                f"{self.model.name}: joint target {np.round(goal, 2).tolist()} "
                f"needs pulses {bad} outside {S.PULSE_MIN}-{S.PULSE_MAX} us"
            )
        return goal, pulses

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
        """Pump on a digital output (``#<ch>H`` / ``#<ch>L``), if the profile names one;
        with ``tool: gripper``, close (on) or open (off) the gripper instead."""
        if self.tool_kind == "gripper":
            return self.set_gripper(self.grip_closed if on else self.grip_open)
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
            self._stream = None
            self._moves.clear()
            self._commanded_pulses = None  # stopped mid-ramp: only the read-back is known
        self.stop_all()
        self.remember_sent(None)
        self._last_handle = None
        if self._ser is not None:
            self.write(S.stop_command([m.channel for m in self.servos]))
