"""Small kinematic models for the planning, collision and workspace tests and benchmarks.

``PlanarArm``: a two-link arm turning in a horizontal plane ``height`` mm above
the base. ``DobotLike``: the Dobot V1.0 geometry of Showers 2016 (eqs. 5-10 for the
kinematics, eqs. 11-13 for the link boxes), with limits given by the caller.
"""

from __future__ import annotations

import numpy as np

from armtree.maths.motion.geometry import rot_y, rot_z, transform
from armtree.maths.motion.kinematics import Constraint, Joint, KinematicModel, LinkBox
from armtree.maths.motion.workspace import WorkspaceShape
from armtree.plugins.arms.common.workspace_shapes import dobot_shape


def _offset(x: float, y: float = 0.0, z: float = 0.0) -> np.ndarray:
    return transform(None, np.array([x, y, z], dtype=float))


class PlanarArm(KinematicModel):
    """Two revolute joints about z; link lengths ``l1``, ``l2`` mm; links are 20 mm boxes."""

    def __init__(
        self, l1: float = 200.0, l2: float = 150.0, height: float = 50.0, limit: float = 170.0
    ):
        self.l1, self.l2, self.height = l1, l2, height
        self.name = "planar2r"
        self.joints = (
            Joint("q0", "revolute", -limit, limit),
            Joint("q1", "revolute", -limit, limit),
        )
        self.home = np.array([0.0, 90.0])
        self.boxes = (
            LinkBox("base", 0, (40.0, 40.0, 2 * height), _offset(0, 0, -height / 2)),
            LinkBox("link1", 1, (l1, 20.0, 20.0), _offset(l1 / 2)),
            LinkBox("link2", 2, (l2, 20.0, 20.0), _offset(l2 / 2)),
        )

    def link_frames(self, q: np.ndarray) -> np.ndarray:
        q = np.radians(np.asarray(q, dtype=float))
        shape = q.shape[:-1]
        base = np.broadcast_to(_offset(0, 0, self.height), shape + (4, 4))
        f1 = base @ transform(rot_z(q[..., 0]))
        f2 = f1 @ _offset(self.l1) @ transform(rot_z(q[..., 1]))
        tcp = f2 @ _offset(self.l2)
        return np.stack([base, f1, f2, tcp], axis=-3)

    def ik_all(self, target: np.ndarray) -> np.ndarray:
        p = np.asarray(target, dtype=float)
        x, y = p[..., 0], p[..., 1]
        c2 = (x**2 + y**2 - self.l1**2 - self.l2**2) / (2 * self.l1 * self.l2)
        ok = (np.abs(c2) <= 1) & (np.abs(p[..., 2] - self.height) < 1e-6)
        c2 = np.clip(c2, -1, 1)
        sols = []
        for sign in (1.0, -1.0):
            s2 = sign * np.sqrt(1 - c2**2)
            q1 = np.arctan2(s2, c2)
            q0 = np.arctan2(y, x) - np.arctan2(self.l2 * s2, self.l1 + self.l2 * c2)
            q0 = (q0 + np.pi) % (2 * np.pi) - np.pi
            sols.append(np.degrees(np.stack([q0, q1], axis=-1)))
        out = np.stack(sols, axis=-2)
        out[~ok] = np.nan
        out[~self.within_limits(out)] = np.nan
        return out


class DobotLike(KinematicModel):
    """Dobot V1.0 geometry (Showers 2016): l1 = 135, l2 = 160, d = 55 mm, joints in degrees.

    theta1 is measured from the vertical, theta2 from the horizontal (eqs. 5-7);
    the end effector keeps its orientation (decoupled architecture).
    """

    def __init__(
        self,
        lower: tuple[float, float, float] = (-135.0, 0.0, 0.0),
        upper: tuple[float, float, float] = (135.0, 60.0, 60.0),
        coupled: float | None = 35.0,
        l1: float = 135.0,
        l2: float = 160.0,
        d: float = 55.0,
    ):
        self.l1, self.l2, self.d = l1, l2, d
        self.name = "dobot_like"
        self.joints = tuple(
            Joint(n, "revolute", lo, hi)
            for n, lo, hi in zip(("theta0", "theta1", "theta2"), lower, upper, strict=True)
        )
        if coupled is not None:
            # Showers 2016, eq. 4: theta2 - theta1 >= coupled
            self.constraints = (
                Constraint(
                    "elbow",
                    lambda q: coupled - (q[..., 2] - q[..., 1]),
                    f"{coupled} - (q2 - q1) <= 0",
                ),
            )
        self.home = np.array([0.0, 10.0, 50.0])
        self.boxes = (
            LinkBox("base", 0, (110.0, 110.0, 80.0), _offset(0, 0, -60.0)),
            LinkBox("link1", 1, (30.0, 40.0, l1), _offset(0, 0, l1 / 2)),
            LinkBox("link2", 2, (25.0, 30.0, l2), _offset(0, 0, l2 / 2)),
            LinkBox("end", 3, (d + 20.0, 30.0, 40.0), _offset(d / 2, 0, -10.0)),
            LinkBox("camera", 3, (30.0, 40.0, 30.0), _offset(d / 2, 0, 35.0)),
        )

    def link_frames(self, q: np.ndarray) -> np.ndarray:
        q = np.radians(np.asarray(q, dtype=float))
        shape = q.shape[:-1]
        t0, t1, t2 = q[..., 0], q[..., 1], q[..., 2]
        rz = transform(rot_z(t0))
        base = np.broadcast_to(np.eye(4), shape + (4, 4))
        f1 = rz @ transform(rot_y(t1))  # Showers 2016, eq. 11
        elbow = np.stack([self.l1 * np.sin(t1), np.zeros_like(t1), self.l1 * np.cos(t1)], axis=-1)
        f2 = rz @ transform(rot_y(t2 + np.pi / 2), elbow)  # eq. 12
        wrist = elbow + np.stack(
            [self.l2 * np.cos(t2), np.zeros_like(t2), -self.l2 * np.sin(t2)], axis=-1
        )
        f3 = rz @ transform(None, wrist)  # eq. 13
        tcp = f3 @ _offset(self.d)
        return np.stack([base, f1, f2, f3, tcp], axis=-3)

    def workspace_shape(self) -> WorkspaceShape:
        """The workspace as the Dobot family's constraints, as an arm plugin describes it."""
        return dobot_shape(self, self.l1, self.l2, self.d, 0.0)

    def ik_all(self, target: np.ndarray) -> np.ndarray:
        p = np.asarray(target, dtype=float)
        x, y, z = p[..., 0], p[..., 1], p[..., 2]
        r = np.hypot(x, y)  # Showers 2016, eq. 8
        rho = np.hypot(r - self.d, z)
        with np.errstate(invalid="ignore", divide="ignore"):
            alpha = np.arccos((self.l1**2 + rho**2 - self.l2**2) / (2 * self.l1 * rho))  # eq. 9
            gamma = np.arccos((self.l1**2 + self.l2**2 - rho**2) / (2 * self.l1 * self.l2))
        phi = np.arctan2(z, r - self.d)
        t0 = np.arctan2(y, x)  # eq. 10
        up = np.stack([t0, np.pi / 2 - phi - alpha, np.pi - phi - alpha - gamma], axis=-1)
        down = np.stack([t0, np.pi / 2 - phi + alpha, gamma - np.pi - phi + alpha], axis=-1)
        out = np.degrees(np.stack([up, down], axis=-2))
        out[~np.all(np.isfinite(out), axis=-1)] = np.nan
        out[~self.within_limits(out)] = np.nan
        return out


def wide_dobot() -> DobotLike:
    """A Dobot-like arm with wide limits, for planning problems with room to move."""
    return DobotLike(lower=(-135.0, -10.0, -20.0), upper=(135.0, 85.0, 85.0), coupled=-40.0)
