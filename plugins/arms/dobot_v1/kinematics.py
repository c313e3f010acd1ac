"""Dobot V1.0 kinematics after the RPI report (Showers 2016): limits, FK, analytic IK, link boxes.

Joint convention (Showers 2016, Fig. 3; the status frame's baseAngle, longArmAngle,
shortArmAngle): ``q0`` base rotation about z; ``q1`` rear arm measured from the
vertical, forward positive; ``q2`` forearm measured from the horizontal (not
relative to the rear arm), downward positive. The tool stays level (parallel
linkage). Base frame: origin at the shoulder joint, x forward, z up. Units at
the interface: degrees and mm; radians inside.
"""

from __future__ import annotations

import numpy as np

from armtree.maths.motion.kinematics import Constraint, Joint, KinematicModel, LinkBox
from armtree.maths.motion.workspace import WorkspaceShape

from ..common.workspace_shapes import dobot_shape

#: Rear arm (shoulder to elbow), mm (Showers 2016).
L1 = 135.0
#: Forearm (elbow to wrist joint), mm.
L2 = 160.0
#: Horizontal wrist-to-suction-cup offset of the report, mm (open-dobot uses 50.9).
DEFAULT_TOOL_OFFSET = 55.0
#: Minimum elbow opening, degrees (Showers 2016, eq. 4).
ELBOW_MIN = 35.0


def _elbow_gap(q: np.ndarray) -> np.ndarray:
    # Showers 2016, eq. 4: 35 deg <= q2 - q1, as g(q) <= 0
    q = np.asarray(q, dtype=float)
    return ELBOW_MIN - (q[..., 2] - q[..., 1])


def _translation(p: np.ndarray) -> np.ndarray:
    out = np.zeros(p.shape[:-1] + (4, 4))
    out[..., 0, 0] = out[..., 1, 1] = out[..., 2, 2] = out[..., 3, 3] = 1.0
    out[..., :3, 3] = p
    return out


def _offset(x: float, y: float, z: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


class DobotV1Model(KinematicModel):
    """The Dobot V1.0 as a 3-joint positioning arm (degrees / mm).

    ``tool_offset_mm`` is the report's ``d`` (horizontal wrist-to-tool distance,
    55 mm for the suction cup); ``tool_drop_mm`` lowers the tool centre below
    the wrist joint (0 in the report's model). Joint limits are the report's
    conservative eqs. 1-3 with the coupled limit eq. 4 as a :class:`Constraint`.

    ``l1_mm``, ``l2_mm``, ``joint_offsets_deg`` and ``joint_scales`` are what the
    report's least-squares calibration fits (Showers 2016, "Model Validation"): the
    kinematics use ``scale * q + offset`` for each reported angle ``q``, while
    joints, limits and IK solutions stay in the arm's reported angles.
    """

    name = "dobot_v1"

    def __init__(
        self,
        tool_offset_mm: float = DEFAULT_TOOL_OFFSET,
        tool_drop_mm: float = 0.0,
        l1_mm: float = L1,
        l2_mm: float = L2,
        joint_offsets_deg: tuple[float, float, float] | np.ndarray = (0.0, 0.0, 0.0),
        joint_scales: tuple[float, float, float] | np.ndarray = (1.0, 1.0, 1.0),
    ):
        self.d = float(tool_offset_mm)
        self.drop = float(tool_drop_mm)
        self.l1 = float(l1_mm)
        self.l2 = float(l2_mm)
        self.joint_offsets = np.asarray(joint_offsets_deg, dtype=float).reshape(3)
        self.joint_scales = np.asarray(joint_scales, dtype=float).reshape(3)
        if np.any(self.joint_scales == 0.0):
            raise ValueError("DobotV1Model: a joint scale of 0 cannot be inverted")
        # Showers 2016, eqs. 1-3 (speeds and accelerations: assumed, the report gives none)
        self.joints = (
            Joint("base", "revolute", -135.0, 135.0, max_speed=90.0, max_accel=180.0),
            Joint("rear_arm", "revolute", 0.0, 60.0, max_speed=60.0, max_accel=120.0),
            Joint("forearm", "revolute", 0.0, 60.0, max_speed=60.0, max_accel=120.0),
        )
        self.constraints = (Constraint("elbow_opening", _elbow_gap, "35 - (q2 - q1) <= 0"),)
        self.home = np.array([0.0, 10.0, 50.0])
        self.tool_offset = np.array([self.d, 0.0, -self.drop])
        self._lower = np.array([j.lower for j in self.joints])
        self._upper = np.array([j.upper for j in self.joints])
        # Showers 2016, eqs. 11-13: rear arm, forearm, end effector and camera boxes
        self.boxes = (
            LinkBox("rear_arm", 0, (30.0, 40.0, self.l1 + 20.0), _offset(0.0, 0.0, self.l1 / 2)),
            LinkBox("forearm", 1, (self.l2 + 20.0, 30.0, 30.0), _offset(self.l2 / 2, 0.0, 0.0)),
            LinkBox(
                "tool",
                2,
                (self.d + 20.0, 30.0, 40.0 + self.drop),
                _offset(self.d / 2, 0.0, -(20.0 + self.drop) / 2),
            ),
            LinkBox("camera", 2, (30.0, 60.0, 30.0), _offset(self.d / 2, 0.0, 25.0)),
        )
        self.self_collision_pairs = ((0, 2), (0, 3))

    @property
    def lower(self) -> np.ndarray:
        """Lower joint limits, degrees."""
        return self._lower

    @property
    def upper(self) -> np.ndarray:
        """Upper joint limits, degrees."""
        return self._upper

    def _radians(self, q: np.ndarray) -> np.ndarray:
        """Model angles in radians for reported joints ``q`` in degrees (scale, then offset)."""
        return np.radians(np.asarray(q, dtype=float) * self.joint_scales + self.joint_offsets)

    # ------------------------------------------------------------------ forward

    def position(self, q: np.ndarray) -> np.ndarray:
        """Tool centre position ``(..., 3)`` in mm for joints ``(..., 3)`` in degrees."""
        q = self._radians(q)
        t0, t1, t2 = q[..., 0], q[..., 1], q[..., 2]
        # Showers 2016, eqs. 5-7
        r = self.l1 * np.sin(t1) + self.l2 * np.cos(t2) + self.d
        out = np.empty(q.shape[:-1] + (3,))
        out[..., 0] = np.cos(t0) * r
        out[..., 1] = np.sin(t0) * r
        out[..., 2] = self.l1 * np.cos(t1) - self.l2 * np.sin(t2) - self.drop
        return out

    def fk(self, q: np.ndarray) -> np.ndarray:
        """Tool pose ``(..., 4, 4)``: at :meth:`position`, level, x pointing radially out."""
        q = np.asarray(q, dtype=float)
        p = self.position(q)
        t0 = self._radians(q)[..., 0]
        out = _translation(p)
        c, s = np.cos(t0), np.sin(t0)
        out[..., 0, 0] = c
        out[..., 0, 1] = -s
        out[..., 1, 0] = s
        out[..., 1, 1] = c
        return out

    def link_frames(self, q: np.ndarray) -> np.ndarray:
        """Frames ``(..., 4, 4, 4)``: rear arm at the shoulder, forearm at the elbow, wrist, tool.

        The rear-arm frame is Rz(q0) Ry(q1) (the link along its z), the forearm frame
        Rz(q0) Ry(q2) at the elbow (the link along its x), as Showers 2016 eqs. 11-13
        rotate the meshes; wrist and tool frames are level, Rz(q0).
        """
        q = self._radians(q)
        t0, t1, t2 = q[..., 0], q[..., 1], q[..., 2]
        c0, s0 = np.cos(t0), np.sin(t0)
        c1, s1 = np.cos(t1), np.sin(t1)
        c2, s2 = np.cos(t2), np.sin(t2)
        frames = np.zeros(q.shape[:-1] + (4, 4, 4))
        frames[..., :, 3, 3] = 1.0

        def rz_ry(k: int, c: np.ndarray, s: np.ndarray) -> None:
            # Rz(q0) @ Ry(angle)
            frames[..., k, 0, 0] = c0 * c
            frames[..., k, 0, 1] = -s0
            frames[..., k, 0, 2] = c0 * s
            frames[..., k, 1, 0] = s0 * c
            frames[..., k, 1, 1] = c0
            frames[..., k, 1, 2] = s0 * s
            frames[..., k, 2, 0] = -s
            frames[..., k, 2, 2] = c

        rz_ry(0, c1, s1)
        rz_ry(1, c2, s2)
        for k in (2, 3):
            frames[..., k, 0, 0] = c0
            frames[..., k, 0, 1] = -s0
            frames[..., k, 1, 0] = s0
            frames[..., k, 1, 1] = c0
            frames[..., k, 2, 2] = 1.0
        # Showers 2016, eqs. 12-13: each link offset by the preceding link lengths
        elbow_r, elbow_z = self.l1 * s1, self.l1 * c1
        wrist_r, wrist_z = elbow_r + self.l2 * c2, elbow_z - self.l2 * s2
        tool_r, tool_z = wrist_r + self.d, wrist_z - self.drop
        for k, (r, z) in ((1, (elbow_r, elbow_z)), (2, (wrist_r, wrist_z)), (3, (tool_r, tool_z))):
            frames[..., k, 0, 3] = c0 * r
            frames[..., k, 1, 3] = s0 * r
            frames[..., k, 2, 3] = z
        return frames

    def jacobian(self, q: np.ndarray, eps: float = 1e-4) -> np.ndarray:
        """Positional Jacobian ``(..., 3, 3)`` in mm per degree, analytic (``eps`` unused)."""
        q = self._radians(q)
        t0, t1, t2 = q[..., 0], q[..., 1], q[..., 2]
        c0, s0 = np.cos(t0), np.sin(t0)
        r = self.l1 * np.sin(t1) + self.l2 * np.cos(t2) + self.d
        j = np.zeros(q.shape[:-1] + (3, 3))
        j[..., 0, 0] = -s0 * r
        j[..., 1, 0] = c0 * r
        j[..., 0, 1] = c0 * self.l1 * np.cos(t1)
        j[..., 1, 1] = s0 * self.l1 * np.cos(t1)
        j[..., 2, 1] = -self.l1 * np.sin(t1)
        j[..., 0, 2] = -c0 * self.l2 * np.sin(t2)
        j[..., 1, 2] = -s0 * self.l2 * np.sin(t2)
        j[..., 2, 2] = -self.l2 * np.cos(t2)
        # chain rule through the reading correction: d(model angle)/dq = scale
        return j * (np.pi / 180.0) * self.joint_scales

    # ------------------------------------------------------------------ inverse

    def workspace_shape(self) -> WorkspaceShape | None:
        """The reachable tool positions as constraints (Showers 2016's geometry), or None
        with calibrated angle offsets or scales, which the constraints do not model."""
        if np.any(self.joint_offsets != 0.0) or np.any(self.joint_scales != 1.0):
            return None
        return dobot_shape(self, self.l1, self.l2, self.d, self.drop)

    def ik_all(self, target: np.ndarray) -> np.ndarray:
        """Both elbow branches ``(..., 2, 3)`` in degrees for tool positions ``(..., 3)`` mm.

        Branch 0 is the report's solution (eq. 10); branch 1 the elbow reversed,
        which the report's limits always exclude. Rows outside the limits, the
        coupled limit or the reach are NaN.
        """
        target = np.asarray(target, dtype=float)
        if target.shape[-2:] == (4, 4):
            target = target[..., :3, 3]
        x, y = target[..., 0], target[..., 1]
        z = target[..., 2] + self.drop
        l1, l2 = self.l1, self.l2
        # Showers 2016, eq. 8
        r = np.hypot(x, y)
        rd = r - self.d
        rho2 = rd * rd + z * z
        rho = np.sqrt(rho2)
        with np.errstate(invalid="ignore", divide="ignore"):
            # Showers 2016, eq. 9 (law of cosines; NaN outside the reach)
            cos_a = (l1 * l1 + rho2 - l2 * l2) / (2.0 * l1 * rho)
            cos_g = (l1 * l1 + l2 * l2 - rho2) / (2.0 * l1 * l2)
            alpha = np.arccos(np.where(np.abs(cos_a) <= 1.0, cos_a, np.nan))
            gamma = np.arccos(np.where(np.abs(cos_g) <= 1.0, cos_g, np.nan))
        phi = np.arctan2(z, rd)
        # Showers 2016, eq. 10
        t0 = np.arctan2(y, x)
        half_pi = 0.5 * np.pi
        out = np.empty(target.shape[:-1] + (2, 3))
        out[..., 0, 0] = t0
        out[..., 0, 1] = half_pi - phi - alpha
        out[..., 0, 2] = np.pi - phi - alpha - gamma
        out[..., 1, 0] = t0
        out[..., 1, 1] = half_pi - phi + alpha
        out[..., 1, 2] = gamma - np.pi - phi + alpha
        out = (np.degrees(out) - self.joint_offsets) / self.joint_scales
        ok = np.all((out >= self._lower - 1e-9) & (out <= self._upper + 1e-9), axis=-1)
        ok &= (out[..., 2] - out[..., 1]) >= ELBOW_MIN - 1e-9
        out[~ok] = np.nan
        return out
