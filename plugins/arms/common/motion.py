"""Joint motion on the run's clock: synchronised trapezoidal moves and braking.

Emulators (and hosts that plan their own steps, such as open-dobot) use these
to know where the joints are at any time ``t``. A position is a closed-form
function of ``t`` and the commands received, never of how often it is sampled,
so motion is identical whatever the tick rate. Units: degrees / mm and seconds.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class _Segment:
    """Path parameter ``s`` under constant acceleration from ``t0``: s0 + v0 dt + a dt^2 / 2."""

    t0: float
    s0: float
    v0: float
    a: float
    t1: float


class JointMove:
    """One synchronised move from ``start`` to ``goal``: every joint starts and stops together.

    The path is ``q(t) = start + (goal - start) * s(t)`` with ``s`` going 0 -> 1
    on a trapezoidal (or triangular) speed profile whose peak speed and
    acceleration keep every joint within ``max_speed`` and ``max_accel``
    (arrays, per joint, units per second and per second squared) scaled by
    ``speed`` (a fraction of the maximum, 0 < speed <= 1).
    """

    def __init__(
        self,
        start: np.ndarray,
        goal: np.ndarray,
        t0: float,
        max_speed: np.ndarray,
        max_accel: np.ndarray,
        speed: float = 1.0,
    ) -> None:
        self.start = np.asarray(start, dtype=float).copy()
        self.goal = np.asarray(goal, dtype=float).copy()
        self.t0 = float(t0)
        delta = np.abs(self.goal - self.start)
        moving = delta > 1e-12
        speed = float(min(1.0, max(speed, 1e-3)))
        self._accel = 0.0
        if not np.any(moving):
            self._segments = [_Segment(self.t0, 1.0, 0.0, 0.0, self.t0)]
            return
        v = speed * float(np.min(np.asarray(max_speed, dtype=float)[moving] / delta[moving]))
        a = speed * float(np.min(np.asarray(max_accel, dtype=float)[moving] / delta[moving]))
        ta = v / a
        if v * ta >= 1.0:  # triangular: never reaches the peak speed
            ta = float(np.sqrt(1.0 / a))
            v = a * ta
            cruise = 0.0
        else:
            cruise = (1.0 - v * ta) / v
        t1 = self.t0 + ta
        t2 = t1 + cruise
        self._segments = [
            _Segment(self.t0, 0.0, 0.0, a, t1),
            _Segment(t1, 0.5 * a * ta * ta, v, 0.0, t2),
            _Segment(t2, 1.0 - 0.5 * a * ta * ta, v, -a, t2 + ta),
        ]
        self._accel = a

    @property
    def end_time(self) -> float:
        """When the joints come to rest, seconds on the run clock."""
        return self._segments[-1].t1

    def _s(self, t: float) -> tuple[float, float]:
        for seg in self._segments:
            if t <= seg.t1:
                dt = max(0.0, t - seg.t0)
                return seg.s0 + seg.v0 * dt + 0.5 * seg.a * dt * dt, seg.v0 + seg.a * dt
        last = self._segments[-1]
        dt = last.t1 - last.t0
        return last.s0 + last.v0 * dt + 0.5 * last.a * dt * dt, 0.0

    def position(self, t: float) -> np.ndarray:
        """Joint positions at time ``t`` (held at the ends outside the move)."""
        s, _ = self._s(t)
        return self.start + (self.goal - self.start) * s

    def velocity(self, t: float) -> np.ndarray:
        """Joint velocities at time ``t``."""
        _, ds = self._s(t)
        return (self.goal - self.start) * ds

    def done(self, t: float) -> bool:
        """True once the joints are at rest at the goal (or braked to rest)."""
        return t >= self.end_time

    def brake(self, t: float) -> None:
        """Decelerate to rest along the same path from time ``t``, as a stop command does."""
        if t >= self.end_time:
            return
        s, ds = self._s(t)
        a = self._accel
        if ds <= 0.0 or a <= 0.0:
            self._segments = [_Segment(t, s, 0.0, 0.0, t)]
            return
        tb = ds / a
        self._segments = [_Segment(t, s, ds, -a, t + tb)]


class LineMove:
    """A straight tool line from joints ``start_q`` to ``goal_q``, joints found by IK.

    ``fk(q)`` gives tool positions (mm) and ``ik(points)`` joints for ``(..., 3)``
    points (NaN where unreachable); the line runs at ``max_speed`` (mm/s) and
    ``max_accel`` (mm/s^2) scaled by ``speed``. Where a point of the line has
    no IK solution the joints take the joint-interpolated pose at the same
    fraction of the way, so the position stays a function of ``t`` alone.
    """

    def __init__(
        self,
        ik: Callable[[np.ndarray], np.ndarray],
        start_q: np.ndarray,
        goal_q: np.ndarray,
        fk: Callable[[np.ndarray], np.ndarray],
        t0: float,
        max_speed: float,
        max_accel: float,
        speed: float = 1.0,
    ) -> None:
        self._ik = ik
        self._q0 = np.asarray(start_q, dtype=float).copy()
        self._q1 = np.asarray(goal_q, dtype=float).copy()
        self._p0 = np.asarray(fk(self._q0), dtype=float)
        self._p1 = np.asarray(fk(self._q1), dtype=float)
        self._length = float(np.linalg.norm(self._p1 - self._p0))
        self._line = JointMove(
            self._p0, self._p1, t0, np.full(3, max_speed), np.full(3, max_accel), speed
        )

    @property
    def end_time(self) -> float:
        """When the tool comes to rest, seconds."""
        return self._line.end_time

    def position(self, t: float) -> np.ndarray:
        """Joint positions at ``t``."""
        p = self._line.position(t)
        if self._length <= 1e-9:
            return self._q1.copy()
        s = float(np.linalg.norm(p - self._p0)) / self._length
        if s >= 1.0 - 1e-12:
            return self._q1.copy()
        q = np.asarray(self._ik(p), dtype=float)
        if np.all(np.isfinite(q)):
            return q
        return self._q0 + (self._q1 - self._q0) * s

    def velocity(self, t: float, dt: float = 1e-4) -> np.ndarray:
        """Joint velocities at ``t`` (central differences)."""
        return (self.position(t + dt) - self.position(t - dt)) / (2 * dt)

    def done(self, t: float) -> bool:
        """True once the tool is at rest."""
        return self._line.done(t)

    def brake(self, t: float) -> None:
        """Decelerate along the line from ``t``."""
        self._line.brake(t)


class JointState:
    """Where an emulated arm's joints are: the current move, braking and missed steps.

    ``reported`` is what the firmware believes (its step counters); ``true``
    adds the offsets of missed steps, as an open-loop stepper arm would.
    """

    def __init__(self, q0: np.ndarray, max_speed: np.ndarray, max_accel: np.ndarray) -> None:
        self.max_speed = np.asarray(max_speed, dtype=float)
        self.max_accel = np.asarray(max_accel, dtype=float)
        self._rest = np.asarray(q0, dtype=float).copy()
        self._move: JointMove | LineMove | None = None
        self.missed = np.zeros_like(self._rest)

    def reported(self, t: float) -> np.ndarray:
        """Joint positions the firmware would report at ``t``."""
        return self._move.position(t) if self._move is not None else self._rest.copy()

    def true(self, t: float) -> np.ndarray:
        """Joint positions in the world at ``t`` (missed steps included)."""
        return self.reported(t) + self.missed

    @property
    def end_time(self) -> float:
        """When the current move (or brake) ends, seconds; ``-inf`` when there is none."""
        return self._move.end_time if self._move is not None else float("-inf")

    def moving(self, t: float) -> bool:
        """True while a move or a brake is under way at ``t``."""
        return self._move is not None and not self._move.done(t)

    def move_to(self, goal: np.ndarray, t: float, speed: float = 1.0) -> JointMove:
        """Start a move at ``t`` from where the joints are then (from rest)."""
        start = self.reported(t)
        self._move = JointMove(start, goal, t, self.max_speed, self.max_accel, speed)
        return self._move

    def start(self, move: JointMove | LineMove) -> JointMove | LineMove:
        """Install a move built by the caller (a :class:`LineMove`, say)."""
        self._move = move
        return move

    def brake(self, t: float) -> None:
        """Decelerate to rest from ``t``."""
        if self._move is not None:
            self._move.brake(t)

    def halt(self, t: float) -> None:
        """Stop dead at ``t`` (a crash or an e-stop cutting the drivers)."""
        self._rest = self.reported(t)
        self._move = None

    def set(self, q: np.ndarray) -> None:
        """Place the joints at ``q`` at rest (power-up, counters reset)."""
        self._rest = np.asarray(q, dtype=float).copy()
        self._move = None

    def rereference(self, believed: np.ndarray, t: float) -> None:
        """The firmware's belief becomes ``believed`` (at rest) at ``t``; the world position stays.

        A board that re-reads its pose from sensors (accelerometers at boot) does
        this: the offsets of missed steps become whatever the new belief is off by.
        """
        true = self.true(t)
        self._rest = np.asarray(believed, dtype=float).copy()
        self._move = None
        self.missed = true - self._rest

    def miss_steps(self, joint: int, amount: float) -> None:
        """The world position of ``joint`` slips by ``amount`` (deg / mm) unknown to the firmware."""
        self.missed[joint] += amount
