"""VICRA SCARA geometry (Durovic 2017, §III.A): a vertical prismatic column and two arm links.

Durovic 2017 gives "one translational and three rotational joints", "vertical reach
of approximately 0.6 m" and "horizontal reach of approximately 0.6 m", a servo
wrist and a servo gripper. This model fixes the rest, overridable in a profile:

* ``z``: carriage height, 0-600 mm; ``z = 0`` puts the tool tip on the table.
* ``theta1`` (shoulder, -160..160 deg) and ``theta2`` (elbow, -150..150 deg)
  with links L1 = L2 = 300 mm, so the reach is 0.6 m.
* ``wrist``: the DC/servo wrist, -90..90 deg (servo 0..180 deg), tool yaw.

    x = L1 cos t1 + L2 cos(t1 + t2),  y = L1 sin t1 + L2 sin(t1 + t2),  z = z,
    yaw = t1 + t2 + wrist

Degrees and mm at the edges, radians inside.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from armtree.maths.motion.kinematics import Joint, KinematicModel, LinkBox
from armtree.maths.motion.workspace import WorkspaceShape

from ..common.workspace_shapes import scara_shape

#: Degrees / mm by which an IK solution may miss a limit through round-off and be clamped.
LIMIT_SLACK = 1e-5

#: Height of the arm plane above the tool tip (the gripper hangs this far below it), mm.
TOOL_DROP = 80.0


class VicraModel(KinematicModel):
    """Closed-form, batched SCARA kinematics of the VICRA arm.

    Joints ``(z, theta1, theta2, wrist)`` in mm and degrees. ``ik_all`` returns
    the elbow-right (theta2 > 0) and elbow-left branches, ``(..., 2, 4)``;
    ``(..., 3)`` targets keep the wrist at 0, ``(..., 4, 4)`` targets set it
    from the tool yaw.
    """

    def __init__(
        self,
        l1: float = 300.0,
        l2: float = 300.0,
        z_travel: float = 600.0,
        limits: Sequence[tuple[float, float]] = ((-160, 160), (-150, 150), (-90, 90)),
    ) -> None:
        self.name = "vicra"
        self.l1, self.l2 = float(l1), float(l2)
        (t1lo, t1hi), (t2lo, t2hi), (wlo, whi) = limits
        self.joints = (
            Joint("z", "prismatic", 0.0, float(z_travel), max_speed=100.0, max_accel=400.0),
            Joint("theta1", "revolute", float(t1lo), float(t1hi), max_speed=90.0, max_accel=360.0),
            Joint("theta2", "revolute", float(t2lo), float(t2hi), max_speed=90.0, max_accel=360.0),
            Joint("wrist", "revolute", float(wlo), float(whi), max_speed=180.0, max_accel=1800.0),
        )
        self.tool_offset = np.array([0.0, 0.0, -TOOL_DROP])
        self.home = np.array([200.0, -45.0, 90.0, 0.0])
        #: Where G28 leaves the arm: column at the top (z_max), shoulder on its x_min and
        #: elbow on its y_max switch (the elbow side of the home pose), wrist centred.
        #: Also where it is parked when switched off.
        self.park = np.array([float(z_travel), float(t1lo), float(t2hi), 0.0])
        self.boxes = (
            LinkBox(
                "column",
                0,
                (120.0, 120.0, z_travel + TOOL_DROP + 100),
                _shift(0, 0, (z_travel + TOOL_DROP + 100) / 2),
            ),
            LinkBox("link1", 1, (self.l1 + 80, 80.0, 60.0), _shift(self.l1 / 2, 0, 0)),
            LinkBox("link2", 2, (self.l2 + 60, 60.0, 50.0), _shift(self.l2 / 2, 0, 0)),
            LinkBox("gripper", 3, (60.0, 60.0, TOOL_DROP), _shift(0, 0, -TOOL_DROP / 2)),
        )
        self.self_collision_pairs = ((0, 2), (0, 3))

    def link_frames(self, q: np.ndarray) -> np.ndarray:
        """Base, shoulder, elbow, wrist and tool frames: ``(..., 5, 4, 4)``, mm.

        The shoulder frame rides the carriage at height ``z + TOOL_DROP`` and
        turns by theta1; the elbow frame sits at the end of link 1; the wrist
        frame at the end of link 2, turned by the wrist; the tool hangs below it.
        """
        q = np.asarray(q, dtype=float)
        z = q[..., 0]
        t1, t2, w = (np.radians(q[..., i]) for i in (1, 2, 3))
        a1, a12, a123 = t1, t1 + t2, t1 + t2 + w
        out = np.zeros((*q.shape[:-1], 5, 4, 4))
        out[..., :, 3, 3] = 1.0
        out[..., :, 2, 2] = 1.0
        out[..., 0, 0, 0] = out[..., 0, 1, 1] = 1.0
        h = z + TOOL_DROP
        ex, ey = self.l1 * np.cos(a1), self.l1 * np.sin(a1)
        wx, wy = ex + self.l2 * np.cos(a12), ey + self.l2 * np.sin(a12)
        for i, (ang, px, py, pz) in enumerate(
            ((a1, 0.0, 0.0, h), (a12, ex, ey, h), (a123, wx, wy, h), (a123, wx, wy, z)), start=1
        ):
            c, s = np.cos(ang), np.sin(ang)
            out[..., i, 0, 0], out[..., i, 0, 1] = c, -s
            out[..., i, 1, 0], out[..., i, 1, 1] = s, c
            out[..., i, 0, 3], out[..., i, 1, 3], out[..., i, 2, 3] = px, py, pz
        return out

    def fk(self, q: np.ndarray) -> np.ndarray:
        """Tool pose ``(..., 4, 4)`` in mm: vertical, turned by theta1 + theta2 + wrist."""
        q = np.asarray(q, dtype=float)
        yaw = np.radians(q[..., 1] + q[..., 2] + q[..., 3])
        out = np.zeros((*q.shape[:-1], 4, 4))
        c, s = np.cos(yaw), np.sin(yaw)
        out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1] = c, -s, s, c
        out[..., 2, 2] = out[..., 3, 3] = 1.0
        out[..., :3, 3] = self.position(q)
        return out

    def position(self, q: np.ndarray) -> np.ndarray:
        """Tool position ``(..., 3)`` in mm, closed form."""
        q = np.asarray(q, dtype=float)
        t1, t12 = np.radians(q[..., 1]), np.radians(q[..., 1] + q[..., 2])
        x = self.l1 * np.cos(t1) + self.l2 * np.cos(t12)
        y = self.l1 * np.sin(t1) + self.l2 * np.sin(t12)
        return np.stack([x, y, q[..., 0]], axis=-1)

    def workspace_shape(self) -> WorkspaceShape:
        """The reachable tool positions as a SCARA arm's constraints (mm)."""
        return scara_shape(self, self.l1, self.l2)

    def ik_all(self, target: np.ndarray) -> np.ndarray:
        """Elbow-right and elbow-left solutions, ``(..., 2, 4)``; NaN outside limits or reach."""
        target = np.asarray(target, dtype=float)
        if target.shape[-2:] == (4, 4):
            p = target[..., :3, 3]
            yaw = np.degrees(np.arctan2(target[..., 1, 0], target[..., 0, 0]))
        else:
            p, yaw = target, None
        x, y, z = p[..., 0], p[..., 1], p[..., 2]
        r2 = x * x + y * y
        c2 = (r2 - self.l1**2 - self.l2**2) / (2 * self.l1 * self.l2)
        c2 = np.where(np.abs(c2) <= 1 + 1e-12, np.clip(c2, -1.0, 1.0), np.nan)
        sols = []
        for sign in (1.0, -1.0):
            t2 = sign * np.arccos(c2)
            t1 = np.arctan2(y, x) - np.arctan2(self.l2 * np.sin(t2), self.l1 + self.l2 * np.cos(t2))
            t1d, t2d = np.degrees(t1), np.degrees(t2)
            t1d = (t1d + 180.0) % 360.0 - 180.0
            w = np.zeros_like(x) if yaw is None else (yaw - t1d - t2d + 180.0) % 360.0 - 180.0
            sols.append(np.stack([z, t1d, t2d, w], axis=-1))
        out = np.stack(sols, axis=-2)
        # round-off at a stretched arm can put a limit-value solution a hair outside
        lo, hi = self.lower, self.upper
        out = np.where((out < lo) & (out > lo - LIMIT_SLACK), lo, out)
        out = np.where((out > hi) & (out < hi + LIMIT_SLACK), hi, out)
        ok = self.within_limits(out)
        return np.where(ok[..., None], out, np.nan)


def _shift(x: float, y: float, z: float) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = (x, y, z)
    return t
