"""Magician PTP paths on the run's clock: joint (MOVJ), straight-line (MOVL) and JUMP moves.

A :class:`Path` is a chain of segments, each a closed-form function of time,
so the emulator's joints depend only on the commands and the clock. MOVL
segments move the tool along a straight line with a trapezoidal speed profile
(:class:`~armtree.plugins.arms.common.motion.JointMove` over x, y, z, r) and
solve the Magician's inverse kinematics at each sample. Units: mm, degrees, s.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from armtree.plugins.arms.common.motion import JointMove, JointState

from .kinematics import MagicianModel


@dataclass
class _Segment:
    move: JointMove
    #: maps the move's coordinates to joint angles (identity for joint moves)
    to_joints: Callable[[np.ndarray], np.ndarray] | None


class Path:
    """Segments run back to back; duck-types the ``JointMove`` interface ``JointState`` uses."""

    def __init__(self, segments: Sequence[_Segment]) -> None:
        self._segments = list(segments)

    @property
    def end_time(self) -> float:
        """When the last segment comes to rest, seconds."""
        return self._segments[-1].move.end_time

    def _at(self, t: float) -> _Segment:
        for seg in self._segments:
            if t <= seg.move.end_time:
                return seg
        return self._segments[-1]

    def position(self, t: float) -> np.ndarray:
        """Joint angles at ``t``, degrees."""
        seg = self._at(t)
        x = seg.move.position(t)
        return x if seg.to_joints is None else seg.to_joints(x)

    def done(self, t: float) -> bool:
        """True once the whole path is finished (or braked to rest)."""
        return t >= self.end_time

    def brake(self, t: float) -> None:
        """Decelerate the current segment to rest and drop the rest of the path."""
        seg = self._at(t)
        seg.move.brake(t)
        self._segments = [seg]


class MagicianJoints(JointState):
    """Joint state that can follow a :class:`Path` as well as a plain joint move."""

    def follow(self, path: Path) -> None:
        """Start following ``path`` (it begins where the joints are)."""
        self._move = path  # type: ignore[assignment]  # Path duck-types JointMove


class PathPlanner:
    """Builds the paths of every PTP mode from the current PTP parameters.

    ``joint_speed`` / ``joint_accel`` are per joint (deg/s, deg/s^2);
    ``xyz_speed`` / ``xyz_accel`` mm/s; ``r_speed`` / ``r_accel`` deg/s;
    ``ratio`` scales all of them (SetPTPCommonParams, 0-1). ``jump_height``
    and ``z_limit`` (mm) shape JUMP moves.
    """

    def __init__(self, model: MagicianModel) -> None:
        self.model = model
        self.joint_speed = np.full(4, 200.0)
        self.joint_accel = np.full(4, 200.0)
        self.xyz_speed, self.r_speed = 200.0, 200.0
        self.xyz_accel, self.r_accel = 200.0, 200.0
        self.velocity_ratio, self.accel_ratio = 1.0, 1.0
        self.jump_height, self.z_limit = 20.0, 200.0

    def _ik(self, xyzr: np.ndarray, near: np.ndarray) -> np.ndarray:
        sols = self.model.ik_all(xyzr[:3])
        sols = sols[np.all(np.isfinite(sols), axis=-1)]
        if len(sols) == 0:
            raise ValueError(f"{np.round(xyzr, 2).tolist()} is outside the workspace")
        q = sols[np.argmin(np.linalg.norm(sols[:, :3] - near[:3], axis=-1))].copy()
        q[3] = xyzr[3] - q[0]
        return q

    def joint_segment(self, q0: np.ndarray, q1: np.ndarray, t0: float) -> _Segment:
        """MOVJ: every joint moves together to ``q1`` (degrees)."""
        move = JointMove(
            q0, q1, t0, self.joint_speed * self.velocity_ratio, self.joint_accel * self.accel_ratio
        )
        return _Segment(move, None)

    def line_segment(
        self, p0: np.ndarray, p1: np.ndarray, q_start: np.ndarray, t0: float
    ) -> _Segment:
        """MOVL: the tool runs the straight line ``p0 -> p1`` (x, y, z mm and r deg)."""
        vmax = np.array([self.xyz_speed] * 3 + [self.r_speed]) * self.velocity_ratio
        amax = np.array([self.xyz_accel] * 3 + [self.r_accel]) * self.accel_ratio
        # straight line: the three axes share one profile, so limit by the path length
        d = np.linalg.norm(p1[:3] - p0[:3])
        if d > 0:
            scale = np.abs(p1[:3] - p0[:3]) / d
            vmax[:3] = np.maximum(self.xyz_speed * self.velocity_ratio * scale, 1e-9)
            amax[:3] = np.maximum(self.xyz_accel * self.accel_ratio * scale, 1e-9)
        # every sample of the line must be reachable before the arm moves
        for s in np.linspace(0.0, 1.0, 21):
            self._ik(p0 + (p1 - p0) * s, q_start)
        move = JointMove(p0, p1, t0, vmax, amax)
        return _Segment(move, lambda p: self._ik(p, q_start))

    def plan(self, mode: int, target: np.ndarray, q0: np.ndarray, t0: float) -> Path:
        """The path of PTP ``mode`` from joints ``q0`` to ``target`` (the command's four floats).

        Raises ValueError when the target or the line to it is unreachable,
        which the firmware answers by not moving.
        """
        target = np.asarray(target, dtype=float)
        p0 = self.model.pose_xyzr(q0)
        if mode in (0, 1, 2, 9, 8):
            p1 = p0 + target if mode == 8 else target.copy()
            q1 = self._ik(p1, q0)
        elif mode in (3, 4, 5, 6):
            q1 = q0 + target if mode == 6 else target.copy()
            p1 = self.model.pose_xyzr(q1)
        elif mode == 7:
            p1 = p0 + target
            q1 = self._ik(p1, q0)
        else:
            raise ValueError(f"unknown PTP mode {mode}")
        if not self.model.within_limits(q1):
            raise ValueError(f"joint target {np.round(q1, 2).tolist()} is outside the limits")
        if mode in (1, 4, 6, 8):
            return Path([self.joint_segment(q0, q1, t0)])
        if mode in (2, 5, 7):
            return Path([self.line_segment(p0, p1, q0, t0)])
        # JUMP (0, 3, 9): up, across, down; the top is capped by z_limit
        top = min(max(p0[2], p1[2]) + self.jump_height, max(self.z_limit, p0[2], p1[2]))
        a = p0.copy()
        a[2] = top
        b = p1.copy()
        b[2] = top
        up = self.line_segment(p0, a, q0, t0)
        qa = self._ik(a, q0)
        if mode == 9:
            across = self.line_segment(a, b, qa, up.move.end_time)
        else:
            across = self.joint_segment(qa, self._ik(b, q1), up.move.end_time)
        down = self.line_segment(b, p1, q1, across.move.end_time)
        return Path([up, across, down])
