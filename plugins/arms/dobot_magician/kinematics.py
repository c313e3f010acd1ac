"""Dobot Magician geometry: base yaw, rear arm, forearm (parallelogram), servo wrist.

The Dobot DLL and pydobot 1.3.2 fix the conventions: the Cartesian
origin is at the centre of the three motors (the rear-arm pivot), positive joint
rotation is counter-clockwise, J2 is measured from the vertical Z axis and J3
from the horizontal (as on the V1). Link lengths and ranges are not given
there; this model uses the published Magician figures, overridable in the
profile: rear arm 135 mm, forearm 147 mm, end-effector offset 59.7 mm forward
(suction cup), ranges J1 ±90°, J2 0-85°, J3 -10-90°, J4 ±90°.

The forearm is kept level by the parallelogram, so the tool hangs at a fixed
horizontal offset from the wrist:

    x = cos J1 (L1 sin J2 + L2 cos J3 + Lx),  y = sin J1 (...),
    z = L1 cos J2 - L2 sin J3 - Lz,           r = J1 + J4

Angles in degrees at the edges, radians inside.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from armtree.maths.motion.kinematics import Joint, KinematicModel, LinkBox
from armtree.maths.motion.workspace import WorkspaceShape

from ..common.workspace_shapes import dobot_shape

#: Degrees / mm by which an IK solution may miss a limit through round-off and be clamped.
LIMIT_SLACK = 1e-5


class MagicianModel(KinematicModel):
    """Closed-form, batched kinematics of the Dobot Magician (mm, degrees).

    Joints ``j1`` (base), ``j2`` (rear arm from vertical), ``j3`` (forearm from
    horizontal), ``j4`` (end-effector servo). ``ik_all`` takes ``(..., 3)``
    positions (``j4`` = 0) or ``(..., 4, 4)`` poses (``j4`` from the tool yaw)
    and returns both elbow branches, ``(..., 2, 4)``.
    """

    def __init__(
        self,
        l1: float = 135.0,
        l2: float = 147.0,
        tool_offset: Sequence[float] = (59.7, 0.0, 0.0),
        limits: Sequence[tuple[float, float]] = ((-90, 90), (0, 85), (-10, 90), (-90, 90)),
    ) -> None:
        self.name = "dobot_magician"
        self.l1, self.l2 = float(l1), float(l2)
        self.tool_offset = np.asarray(tool_offset, dtype=float)
        names = ("j1", "j2", "j3", "j4")
        speeds = (320.0, 320.0, 320.0, 480.0)  # the firmware's default PTP joint velocities, deg/s
        self.joints = tuple(
            Joint(n, "revolute", float(lo), float(hi), max_speed=v, max_accel=2 * v)
            for n, (lo, hi), v in zip(names, limits, speeds, strict=True)
        )
        self.home = np.array([0.0, 45.0, 45.0, 0.0])
        self.boxes = (
            LinkBox("base", 0, (160.0, 160.0, 120.0), _shift(0, 0, -90)),
            LinkBox("rear_arm", 1, (40.0, 50.0, self.l1), _shift(0, 0, self.l1 / 2)),
            LinkBox("forearm", 2, (self.l2, 40.0, 40.0), _shift(self.l2 / 2, 0, 0)),
            # on the tool frame, so it moves rigidly with the tool (and an eye-in-hand
            # camera): from the wrist to the nozzle, its bottom 20 mm under the wrist
            LinkBox(
                "end_effector",
                4,
                (abs(self.tool_offset[0]) + 20, 30.0, 60.0),
                _shift(-self.tool_offset[0] / 2, -self.tool_offset[1], self.tool_offset[2] - 20),
            ),
        )
        self.self_collision_pairs = ((0, 2), (0, 3))

    def link_frames(self, q: np.ndarray) -> np.ndarray:
        """Base, rear-arm, forearm, wrist and tool frames: ``(..., 5, 4, 4)``, mm.

        Frame 1 sits at the rear-arm pivot tilted by J2 (its z along the rear
        arm); frame 2 at the elbow, level, x along the forearm; frame 3 at the
        wrist, rotated by J4; frame 4 is the tool centre.
        """
        q = np.asarray(q, dtype=float)
        j1, j2, j3, j4 = np.radians(np.moveaxis(q, -1, 0))
        c1, s1 = np.cos(j1), np.sin(j1)
        lead = q.shape[:-1]
        out = np.zeros((*lead, 5, 4, 4))
        out[..., :, 3, 3] = 1.0
        yaw = _rot_z(c1, s1)
        out[..., 0, :3, :3] = np.eye(3)
        # rear arm: yaw then pitch about the arm's y axis by J2 (from vertical)
        c2, s2 = np.cos(j2), np.sin(j2)
        out[..., 1, :3, :3] = yaw @ _rot_y(c2, s2)
        reach_elbow = self.l1 * s2
        z_elbow = self.l1 * c2
        out[..., 2, :3, :3] = yaw @ _rot_y(np.cos(j3), np.sin(j3))
        _set_radial(out[..., 2, :3, 3], c1, s1, reach_elbow, z_elbow)
        reach_wrist = reach_elbow + self.l2 * np.cos(j3)
        z_wrist = z_elbow - self.l2 * np.sin(j3)
        out[..., 3, :3, :3] = _rot_z(np.cos(j1 + j4), np.sin(j1 + j4))
        _set_radial(out[..., 3, :3, 3], c1, s1, reach_wrist, z_wrist)
        # the tool offset is fixed to the level forearm (x forward), not to the servo
        tx, ty, tz = self.tool_offset
        out[..., 4, :3, :3] = out[..., 3, :3, :3]
        _set_radial(out[..., 4, :3, 3], c1, s1, reach_wrist + tx, z_wrist - tz)
        out[..., 4, 0, 3] -= s1 * ty
        out[..., 4, 1, 3] += c1 * ty
        return out

    def fk(self, q: np.ndarray) -> np.ndarray:
        """Tool pose ``(..., 4, 4)`` in mm: level, turned by r = J1 + J4; closed form."""
        q = np.asarray(q, dtype=float)
        return _pose(self.position(q), np.radians(q[..., 0] + q[..., 3]))

    def position(self, q: np.ndarray) -> np.ndarray:
        """Tool position ``(..., 3)`` in mm, closed form (no frames built)."""
        q = np.asarray(q, dtype=float)
        j1, j2, j3 = np.radians(q[..., 0]), np.radians(q[..., 1]), np.radians(q[..., 2])
        tx, ty, tz = self.tool_offset
        reach = self.l1 * np.sin(j2) + self.l2 * np.cos(j3) + tx
        c1, s1 = np.cos(j1), np.sin(j1)
        z = self.l1 * np.cos(j2) - self.l2 * np.sin(j3) - tz
        return np.stack([c1 * reach - s1 * ty, s1 * reach + c1 * ty, z], axis=-1)

    def workspace_shape(self) -> WorkspaceShape | None:
        """The reachable tool positions as constraints: the Dobot family's geometry
        (Showers 2016) while the tool sits straight ahead of the wrist (no sideways offset)."""
        tx, ty, tz = self.tool_offset
        if ty != 0.0 or tx < 0.0:
            return None
        return dobot_shape(self, self.l1, self.l2, float(tx), float(tz))

    def ik_all(self, target: np.ndarray) -> np.ndarray:
        """Both elbow branches for each target, ``(..., 2, 4)`` degrees; NaN outside limits."""
        target = np.asarray(target, dtype=float)
        if target.shape[-2:] == (4, 4):
            p = target[..., :3, 3]
            r = np.degrees(np.arctan2(target[..., 1, 0], target[..., 0, 0]))
        else:
            p, r = target, None
        x, y, z = p[..., 0], p[..., 1], p[..., 2]
        tx, ty, tz = self.tool_offset
        rho2 = x * x + y * y - ty * ty
        reach_tool = np.sqrt(np.where(rho2 >= 0, rho2, np.nan))
        j1 = np.arctan2(y, x) - np.arctan2(ty, reach_tool)
        rw = reach_tool - tx  # wrist reach in the arm's plane
        zw = z + tz
        # two-link planar problem: rear arm at elevation a = 90 - J2, forearm at -J3
        d2 = rw * rw + zw * zw
        d = np.sqrt(d2)
        cos_in = (self.l1**2 + d2 - self.l2**2) / (2 * self.l1 * np.where(d > 0, d, np.nan))
        inner = np.arccos(np.where(np.abs(cos_in) <= 1 + 1e-12, np.clip(cos_in, -1, 1), np.nan))
        base = np.arctan2(zw, rw)
        sols = []
        for sign in (1.0, -1.0):
            a = base + sign * inner
            fx = rw - self.l1 * np.cos(a)
            fz = zw - self.l1 * np.sin(a)
            j2 = np.pi / 2 - a
            j3 = -np.arctan2(fz, fx)
            deg = np.degrees(np.stack([j1, j2, j3], axis=-1))
            j4 = np.zeros_like(x) if r is None else _wrap(r - deg[..., 0])
            sols.append(np.concatenate([deg, j4[..., None]], axis=-1))
        out = np.stack(sols, axis=-2)
        # round-off at a stretched arm can put a limit-value solution a hair outside
        lo, hi = self.lower, self.upper
        out = np.where((out < lo) & (out > lo - LIMIT_SLACK), lo, out)
        out = np.where((out > hi) & (out < hi + LIMIT_SLACK), hi, out)
        ok = self.within_limits(out)
        return np.where(ok[..., None], out, np.nan)

    def pose_xyzr(self, q: np.ndarray) -> np.ndarray:
        """The firmware's pose report ``(..., 4)``: x, y, z (mm) and r = J1 + J4 (degrees)."""
        q = np.asarray(q, dtype=float)
        return np.concatenate([self.position(q), (q[..., 0] + q[..., 3])[..., None]], axis=-1)


def _pose(p: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """4x4 poses ``(..., 4, 4)`` at positions ``p`` turned by ``yaw`` (radians) about z."""
    out = np.zeros((*p.shape[:-1], 4, 4))
    c, s = np.cos(yaw), np.sin(yaw)
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1] = c, -s, s, c
    out[..., 2, 2] = out[..., 3, 3] = 1.0
    out[..., :3, 3] = p
    return out


def _wrap(a: np.ndarray) -> np.ndarray:
    return (np.asarray(a) + 180.0) % 360.0 - 180.0


def _shift(x: float, y: float, z: float) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = (x, y, z)
    return t


def _rot_z(c: np.ndarray, s: np.ndarray) -> np.ndarray:
    # Filled in place rather than stacked: a tick's single pose pays numpy's call
    # overhead once per element instead of once per stacked row.
    out = np.zeros((*np.shape(c), 3, 3))
    out[..., 0, 0] = out[..., 1, 1] = c
    out[..., 0, 1] = -s
    out[..., 1, 0] = s
    out[..., 2, 2] = 1.0
    return out


def _rot_y(c: np.ndarray, s: np.ndarray) -> np.ndarray:
    out = np.zeros((*np.shape(c), 3, 3))
    out[..., 0, 0] = out[..., 2, 2] = c
    out[..., 0, 2] = s
    out[..., 2, 0] = -s
    out[..., 1, 1] = 1.0
    return out


def _set_radial(
    dst: np.ndarray, c1: np.ndarray, s1: np.ndarray, reach: np.ndarray, z: np.ndarray
) -> None:
    """Write the point ``reach`` out along yaw (cos ``c1``, sin ``s1``) at height ``z`` to ``dst``."""
    dst[..., 0] = c1 * reach
    dst[..., 1] = s1 * reach
    dst[..., 2] = z
