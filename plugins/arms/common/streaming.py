"""Set points along a timed trajectory, for servos that only ramp linearly to them.

An SSC-32 takes a target and a time and moves every listed servo there at a
constant speed: no acceleration limit, no via-points; bus servos given a goal
and a speed (or a time) do the same. To drive an arm along a
cubic or quintic trajectory (Pozzani 2023, eq. 2; :mod:`armtree.maths.motion.trajectory`) the
host sends, every ``period`` seconds, the trajectory's position ``lead``
seconds ahead with that ramp time. Each ramp starts from where the servos are
when it arrives, so a late send leaves no lag behind: the chords stay within
the trajectory's speeds, and between two chords the speed changes by at most
the trajectory's acceleration times the period. Times are seconds on the
run's clock; joints degrees / mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armtree.maths.motion.collision import CollisionChecker
from armtree.maths.motion.penetration import START_CONTACT_MM
from armtree.maths.motion.trajectory import Trajectory, plan_trajectory, validate_trajectory

#: The shortest ramp sent (s): the last set point of a trajectory sent late.
MIN_RAMP_S = 0.02


@dataclass(frozen=True)
class SetPoint:
    """One command: go to ``q`` (deg / mm) in ``ramp_s`` seconds; ``last`` ends the trajectory."""

    q: np.ndarray
    ramp_s: float
    last: bool


class TrajectoryStream:
    """When to send which set point to follow ``trajectory`` started at ``t0`` (run-clock s).

    ``period`` is the time between set points (s); each goes one period ahead
    of the trajectory, or as far ahead as the last send was behind, whichever
    is longer, so a host that is called late still keeps the servos moving.
    """

    def __init__(self, trajectory: Trajectory, t0: float, period: float = 0.05) -> None:
        if not period > 0:
            raise ValueError(f"stream period must be > 0 s, got {period}")
        self.trajectory = trajectory
        self.t0 = float(t0)
        self.period = float(period)
        self.goal = trajectory.position(trajectory.duration)
        self._last_sent: float | None = None
        self.finished = False

    @property
    def duration(self) -> float:
        """The trajectory's duration, s."""
        return self.trajectory.duration

    def due(self, now: float) -> bool:
        """True when the next set point should go out at ``now``."""
        if self.finished:
            return False
        return self._last_sent is None or now >= self._last_sent + self.period - 1e-9

    def next(self, now: float) -> SetPoint:
        """The set point to send at ``now``; the one after the last raises ``StopIteration``."""
        if self.finished:
            raise StopIteration
        elapsed = max(0.0, now - self.t0)
        lead = self.period if self._last_sent is None else max(self.period, now - self._last_sent)
        self._last_sent = now
        ahead = elapsed + lead
        if ahead >= self.duration - 1e-9:
            self.finished = True
            return SetPoint(self.goal.copy(), max(self.duration - elapsed, MIN_RAMP_S), True)
        return SetPoint(self.trajectory.position(ahead), lead, False)

    def progress(self, now: float) -> float:
        """Fraction of the trajectory's time gone by at ``now``, 0 to 1."""
        if self.duration <= 0:
            return 1.0
        return float(min(1.0, max(0.0, (now - self.t0) / self.duration)))


def timed_path(
    path: np.ndarray, kind: str, checker: CollisionChecker, speed: float = 1.0
) -> Trajectory:
    """The validated trajectory (``kind``: cubic or quintic) through joint configurations
    ``path`` ``(N, n)``, within the joints' speed and acceleration limits scaled by ``speed``.

    Raises :class:`~armtree.errors.PlanningError` (reason ``outside_limits``,
    ``too_fast``, ``collision``, ...) saying where along it the path fails. A path from
    a start believed in a shallow contact is taken when its first move only leaves the
    contact (:func:`~armtree.maths.motion.penetration.leaving_run`); the arm then comes to
    rest at the end of that move.
    """
    joints = checker.model.joints
    scale = float(min(max(speed, 0.01), 1.0))
    vmax = np.array([j.max_speed for j in joints]) * scale
    amax = np.array([j.max_accel for j in joints]) * scale
    trajectory = plan_trajectory(path, kind, max_speed=vmax, max_accel=amax)
    report = validate_trajectory(trajectory, checker)
    if not report.ok and report.reason == "collision" and report.index == 0 and len(path) > 1:
        # Believed in contact (a slipped step): come to rest where the first move leaves
        # the contact (a straight move then), and go on from there.
        path = np.asarray(path, dtype=float)
        moved = np.any(np.abs(path[1:] - path[0]) > 1e-12, axis=1)
        k = 1 + int(np.argmax(moved))
        first, rest = (
            plan_trajectory(p, kind, max_speed=vmax, max_accel=amax)
            for p in (path[: k + 1], path[k:])
        )
        trajectory = first.then(rest)
        report = validate_trajectory(trajectory, checker, start_contact_mm=START_CONTACT_MM)
    report.raise_if_bad()
    return trajectory
