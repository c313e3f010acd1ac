"""uArm Swift Pro kinematics, as its firmware V4 computes them (uarm_coord_convert.c).

Joints ``(base, left, right)`` in degrees: the base turns the arm about the
vertical axis (90 points it along +x); ``left`` is the lower arm's and
``right`` the upper arm's angle, both absolute, measured from horizontal (the
parallelogram links keep the end effector level). With the lower arm
``A = 142.07`` mm, the upper arm ``B = 158.81`` mm, the shoulder ``13.2`` mm out
from the base axis and ``107.4`` mm up, and the work mode's tool offsets
(``front``, ``height``; mode 0, the standard suction cup: 56.65, 74.55 mm)::

    s = A cos(left) + B cos(right)          h = A sin(left) - B sin(right)
    theta = base - 90
    x = (s + 13.2 + front) cos(theta)       y = (s + 13.2 + front) sin(theta)
    z = h + 107.4 - height

Limits (firmware V4): left in [-4, 135.6], right in [-4, 119.9], base in [0, 180],
and the angle between the arms ``180 - left - right`` in [10, 151] (a coupled
limit: two constraints). Degrees and mm at the interface, radians inside;
batched over leading dimensions.
"""

from __future__ import annotations

from typing import Any

import armtree.maths.motion.interval as iv
import numpy as np
from armtree.maths.motion.kinematics import Constraint, Joint, KinematicModel, LinkBox
from armtree.maths.motion.workspace import sector_constraint

#: Lower and upper arm lengths, mm (ARM_A, ARM_B).
LOWER_ARM, UPPER_ARM = 142.07, 158.81
#: Shoulder offset from the base axis and height above the base's foot, mm.
SHOULDER_OUT, SHOULDER_UP = 13.2, 107.4
#: Tool offsets (front, height) of each work mode, mm (uarm_common.h, Swift Pro values).
MODES: dict[int, tuple[float, float]] = {
    0: (56.65, 74.55),  # standard suction cup
    1: (64.4, 51.04),  # laser
    2: (56.5, 74.43),  # 3D printing
    3: (69.5, 43.0),  # universal holder / pen
    4: (76.5, 39.0),  # "Pro" flat stepper suction
    5: (76.0, 73.4),  # "Plus" standard stepper suction
    6: (54.5, 77.2),  # touch pen
}
#: Angle between the arms (180 - left - right) allowed by the firmware, degrees.
ARMS_ANGLE = (10.0, 151.0)
#: Round-off by which a solution may miss a limit and be clamped onto it, degrees.
SLACK = 1e-6


class SwiftProModel(KinematicModel):
    """The Swift Pro in one work mode: closed-form FK and IK, the coupled arm-angle limit."""

    def __init__(self, mode: int = 0) -> None:
        if mode not in MODES:
            raise ValueError(f"work mode {mode} has no tool offsets (known: {sorted(MODES)})")
        self.name = "uarm_swift_pro"
        self.mode = mode
        self.front, self.height = MODES[mode]
        # Joint rates are not published; these keep the emulator near the real arm's
        # pace at the SDK's usual speeds (assumed, not measured).
        self.joints = (
            Joint("base", "revolute", 0.0, 180.0, max_speed=100.0, max_accel=400.0),
            Joint("left", "revolute", -4.0, 135.6, max_speed=100.0, max_accel=400.0),
            Joint("right", "revolute", -4.0, 119.9, max_speed=100.0, max_accel=400.0),
        )
        self.constraints = (
            Constraint(
                "arms not folded shut",
                lambda q: ARMS_ANGLE[0] - (180.0 - q[..., 1] - q[..., 2]),
                "10 - (180 - left - right) <= 0",
            ),
            Constraint(
                "arms not stretched open",
                lambda q: (180.0 - q[..., 1] - q[..., 2]) - ARMS_ANGLE[1],
                "(180 - left - right) - 151 <= 0",
            ),
        )
        # The SDK's reset() pose: X200 Y0 Z150 in mode 0.
        self.home = self.ik(np.array([200.0, 0.0, 150.0]), near=np.array([90.0, 100.0, 8.0]))
        self.tool_offset = np.array([self.front, 0.0, -self.height])
        self.boxes = (
            LinkBox(
                "base", 0, (110.0, 110.0, SHOULDER_UP - 10.0), _shift(0, 0, (SHOULDER_UP - 10) / 2)
            ),
            LinkBox("lower arm", 2, (LOWER_ARM + 20.0, 36.0, 30.0), _shift(LOWER_ARM / 2, 0, 0)),
            LinkBox("upper arm", 3, (UPPER_ARM + 20.0, 30.0, 26.0), _shift(UPPER_ARM / 2, 0, 0)),
            LinkBox(
                "end effector",
                4,
                (self.front + 30.0, 40.0, self.height - 10.0),
                _shift(self.front / 2, 0, -(self.height - 10.0) / 2),
            ),
        )
        self.self_collision_pairs = ((0, 2), (0, 3))

    def workspace_constraints(self, p: Any) -> list[Any]:
        """Reachability of tool points ``p`` ``(..., 3)`` mm as ``g_j(p) <= 0``.

        The inverse kinematics in interval-friendly operations (:mod:`armtree.maths.motion.interval`),
        so ``armtree workspace`` can cover the workspace with boxes (Rybak 2016) and the
        planners test targets exactly: the wrist within the arms' reach, ``left``,
        ``right`` and the arms' angle within their limits (elbow-up: the other branch
        never fits them), and the base's half-turn (x >= 0). Works on points
        (arrays) and on boxes (:class:`armtree.maths.motion.interval.Interval`).
        """
        deg = 180.0 / np.pi
        radial = iv.hypot(p[..., 0], p[..., 1]) - self.front - SHOULDER_OUT
        rise = p[..., 2] + self.height - SHOULDER_UP
        d2 = radial**2 + rise**2
        d = iv.sqrt(d2)
        alpha = iv.acos((LOWER_ARM**2 - UPPER_ARM**2 + d2) / (2 * LOWER_ARM * d))
        arms = iv.acos((LOWER_ARM**2 + UPPER_ARM**2 - d2) / (2 * LOWER_ARM * UPPER_ARM)) * deg
        left = (iv.atan2(rise, radial) + alpha) * deg
        right = 180.0 - left - arms
        (b_lo, l_lo, r_lo), (b_hi, l_hi, r_hi) = self.lower, self.upper
        gs = [
            d2 - (LOWER_ARM + UPPER_ARM) ** 2,
            (LOWER_ARM - UPPER_ARM) ** 2 - d2,
            iv.maximum(l_lo - left, left - l_hi),
            iv.maximum(r_lo - right, right - r_hi),
            iv.maximum(ARMS_ANGLE[0] - arms, arms - ARMS_ANGLE[1]),
        ]
        sector = sector_constraint(b_lo - 90.0, b_hi - 90.0)
        if sector is not None:
            gs.append(sector(p))
        return gs

    def workspace_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """A box (mm) holding every reachable tool point."""
        reach = LOWER_ARM + UPPER_ARM + SHOULDER_OUT + self.front
        centre = SHOULDER_UP - self.height
        return (
            np.array([0.0, -reach, centre - LOWER_ARM - UPPER_ARM]),
            np.array([reach, reach, centre + LOWER_ARM + UPPER_ARM]),
        )

    def link_frames(self, q: np.ndarray) -> np.ndarray:
        """Base, turret, lower arm, upper arm, wrist and tool centre frames: ``(..., 6, 4, 4)``.

        The arm frames' x axes run along the arms (pitched up by ``left``, down by
        ``right``); the wrist and tool frames stay level, turned by the base.
        """
        q = np.asarray(q, dtype=float)
        theta = np.radians(q[..., 0] - 90.0)
        left, right = np.radians(q[..., 1]), np.radians(q[..., 2])
        c, s = np.cos(theta), np.sin(theta)
        out = np.zeros((*q.shape[:-1], 6, 4, 4))
        out[..., :, 3, 3] = 1.0
        out[..., 0, :3, :3] = np.eye(3)

        def frame(i: int, pitch: np.ndarray, radial: np.ndarray, z: np.ndarray) -> None:
            cp, sp = np.cos(pitch), np.sin(pitch)
            # rot_z(theta) @ rot_y(-pitch): x along the arm, tilted up by pitch
            out[..., i, 0, 0], out[..., i, 0, 1], out[..., i, 0, 2] = c * cp, -s, -c * sp
            out[..., i, 1, 0], out[..., i, 1, 1], out[..., i, 1, 2] = s * cp, c, -s * sp
            out[..., i, 2, 0], out[..., i, 2, 1], out[..., i, 2, 2] = sp, 0.0, cp
            out[..., i, 0, 3], out[..., i, 1, 3], out[..., i, 2, 3] = radial * c, radial * s, z

        zero = np.zeros_like(theta)
        reach = SHOULDER_OUT + LOWER_ARM * np.cos(left)
        wrist = reach + UPPER_ARM * np.cos(right)
        up = SHOULDER_UP + LOWER_ARM * np.sin(left)
        down = up - UPPER_ARM * np.sin(right)
        frame(1, zero, zero, zero)
        frame(2, left, zero + SHOULDER_OUT, zero + SHOULDER_UP)
        frame(3, -right, reach, up)
        frame(4, zero, wrist, down)
        frame(5, zero, wrist + self.front, down - self.height)
        return out

    def position(self, q: np.ndarray) -> np.ndarray:
        """Tool centre ``(..., 3)`` mm, closed form (the firmware's angle_to_coord)."""
        q = np.asarray(q, dtype=float)
        theta = np.radians(q[..., 0] - 90.0)
        left, right = np.radians(q[..., 1]), np.radians(q[..., 2])
        radial = LOWER_ARM * np.cos(left) + UPPER_ARM * np.cos(right) + SHOULDER_OUT + self.front
        z = LOWER_ARM * np.sin(left) - UPPER_ARM * np.sin(right) + SHOULDER_UP - self.height
        return np.stack([radial * np.cos(theta), radial * np.sin(theta), z], axis=-1)

    def ik_all(self, target: np.ndarray) -> np.ndarray:
        """Both elbow branches for tool positions ``(..., 3)`` mm: ``(..., 2, 3)``, NaN outside.

        Only the elbow-up branch (``left`` above the line to the wrist) fits the
        limits anywhere the arm reaches; the other is kept for completeness.
        """
        target = np.asarray(target, dtype=float)
        p = target[..., :3, 3] if target.shape[-2:] == (4, 4) else target
        x, y, z = p[..., 0], p[..., 1], p[..., 2]
        base = np.degrees(np.arctan2(y, x)) + 90.0
        radial = np.hypot(x, y) - self.front - SHOULDER_OUT
        rise = z + self.height - SHOULDER_UP
        d2 = radial**2 + rise**2
        d = np.sqrt(d2)
        cos_a = (LOWER_ARM**2 + d2 - UPPER_ARM**2) / (2 * LOWER_ARM * np.maximum(d, 1e-12))
        cos_a = np.where(np.abs(cos_a) <= 1 + 1e-12, np.clip(cos_a, -1.0, 1.0), np.nan)
        phi, alpha = np.arctan2(rise, radial), np.arccos(cos_a)
        branches = []
        for sign in (1.0, -1.0):
            left = phi + sign * alpha
            elbow_r = radial - LOWER_ARM * np.cos(left)
            elbow_z = rise - LOWER_ARM * np.sin(left)
            right = -np.arctan2(elbow_z, elbow_r)
            branches.append(np.stack([base, np.degrees(left), np.degrees(right)], axis=-1))
        out = np.stack(branches, axis=-2)
        lo, hi = self.lower, self.upper
        out = np.where((out < lo) & (out > lo - SLACK), lo, out)
        out = np.where((out > hi) & (out < hi + SLACK), hi, out)
        return np.where(self.within_limits(out)[..., None], out, np.nan)


def _shift(x: float, y: float, z: float) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, 3] = (x, y, z)
    return pose
