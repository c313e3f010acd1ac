"""The base of skills that move the arm, and where to put the tool to see or touch a point.

Positions are the tool centre in the arm's base frame, mm. A skill asks the
arm's model what it can reach (``reach.py``) rather than failing on a height
it cannot get to: a Dobot V1.0 within seed 004's joint limits reaches only a
few centimetres of height.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from armtree import Param
from armtree.maths.perception.frames import EYE_IN_HAND, tool_for_camera_over

from .actions import SkillFailure, fmt
from .base import Skill
from .reach import highest_reachable, lowest_reachable, nearest_reachable, reachable

UP = np.array([0.0, 0.0, 1.0])


class ArmSkill(Skill):
    """A skill with the common motion parameters ``speed`` and ``settle_s``."""

    COMMON = (
        Param(
            "speed",
            "float",
            1.0,
            "",
            "fraction of the arm's maximum speed, 0 to 1",
            exclusive_minimum=0.0,
            maximum=1.0,
        ),
        Param(
            "settle_s",
            "float",
            0.15,
            "s",
            "wait after a move before a frame counts",
            minimum=0.0,
            maximum=60.0,
        ),
    )
    #: Parameters of skills that grip with the suction cup.
    GRIP = (
        Param(
            "reach_slack_mm",
            "float",
            4.0,
            "mm",
            "grip this much higher at most when the touching point is out of reach",
            minimum=0.0,
            maximum=100.0,
        ),
    )

    def speed(self) -> float:
        """The ``speed`` parameter, clipped to (0, 1]."""
        return float(min(1.0, max(0.01, self.param("speed"))))

    def settle(self) -> float:
        """The ``settle_s`` parameter."""
        return float(self.param("settle_s"))

    def clearance(self) -> float | None:
        """The lowest tool height while looking around (mm, the profile's
        ``workcell.clearance_z_mm``); None when the profile sets no limit."""
        return self.workcell.clearance_z_mm


def camera_over(
    skill: ArmSkill, point: np.ndarray, height: float, min_height: float = 40.0
) -> np.ndarray:
    """Tool position (mm) putting the camera ``height`` mm over ``point``, or as near as reachable.

    Eye-in-hand: lower heights down to ``min_height`` are tried in 5 mm steps,
    then the reachable tool position nearest the wanted one; the tool never
    goes below the profile's ``workcell.clearance_z_mm``. Eye-to-hand: the tool simply goes
    ``height`` above the point (out of the way is the caller's business).
    Raises :class:`SkillFailure` when nothing near is reachable.
    """
    rig = skill.rig
    model = rig.arm.model
    if rig.camera.mount != EYE_IN_HAND:
        return point + UP * height
    min_z = skill.clearance()
    q_near = rig.arm.joints()

    home_z = float(model.position(model.home)[2])

    def rotation_at(xyz: np.ndarray) -> np.ndarray:
        # the orientation, not the point, matters here: for positioning arms it follows
        # the direction from the base, so a reachable point at home height will do
        for cand in (xyz, np.array([xyz[0], xyz[1], home_z])):
            if reachable(model, cand):
                return model.fk(model.ik(cand, near=q_near))[:3, :3]
        reach = nearest_reachable(model, xyz)
        if reach is None:
            return np.eye(3)
        return model.fk(model.ik(reach, near=q_near))[:3, :3]

    def over(h: float) -> np.ndarray:
        return tool_for_camera_over(model, point, h, rig.camera.extrinsics, rotation_at=rotation_at)

    tool = point + UP * height
    for h in np.arange(height, min(min_height, height) - 1e-9, -5.0):
        tool = over(h)
        if min_z is not None and tool[2] < min_z:
            # raise the camera until the tool clears, and stop lowering
            tool = over(h + min_z - tool[2])
            if reachable(model, tool):
                return tool
            break
        if reachable(model, tool):
            return tool
    near = nearest_reachable(model, tool, min_z=min_z)
    if near is None:
        raise SkillFailure(f"cannot bring the camera over {fmt(point)}: nothing near is reachable")
    return near


def above(skill: Skill, target: np.ndarray, height: float) -> np.ndarray:
    """``target`` raised by ``height`` mm, or by as much of it as the arm can reach."""
    want = target + UP * height
    model = skill.rig.arm.model
    if height <= 0 or reachable(model, want):
        return want
    best = highest_reachable(model, target, target[2], target[2] + height)
    return want if best is None else best


def has_gripper(rig: Any) -> bool:
    """True when the rig's tool (``rig.tool``) is a gripper, not a suction cup."""
    tool = getattr(rig, "tool", None)
    return tool is not None and tool.kind == "gripper"


def grip_point(
    skill: ArmSkill, target: np.ndarray, grasp_offset: float, inward: float = 0.0
) -> np.ndarray:
    """Where the tool touches ``target``: ``grasp_offset`` above it, or up to ``reach_slack_mm``
    higher when that is out of reach (a suction cup grips within a few millimetres), or
    up to ``inward`` mm nearer the arm's base on the same face (a cup holds anywhere on
    an object's top, not only at its marker's centre)."""
    want = target + UP * grasp_offset
    model = skill.rig.arm.model
    if reachable(model, want):
        return want
    slack = float(skill.param("reach_slack_mm"))
    best = lowest_reachable(model, want, want[2], want[2] + slack)
    if best is not None or inward <= 0.0:
        return want if best is None else best
    radius = float(np.hypot(want[0], want[1]))
    if radius < 1e-6:
        return want
    toward = -np.array([want[0], want[1], 0.0]) / radius
    for step in np.arange(1.0, inward + 1e-9, 1.0):
        moved = want + toward * step
        best = lowest_reachable(model, moved, moved[2], moved[2] + slack)
        if best is not None:
            return best
    return want


__all__ = ["UP", "ArmSkill", "above", "camera_over", "grip_point", "has_gripper"]
