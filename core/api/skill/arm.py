"""The base of skills that move the arm, and where to put the tool to see a point or rise over it.

Positions are the tool centre in the arm's base frame, mm. A skill asks the
arm's model what it can reach (``reach.py``) rather than failing on a height
it cannot get to: a Dobot V1.0 within Showers 2016's joint limits reaches only a
few centimetres of height.
"""

from __future__ import annotations

import numpy as np

from armtree.api.rig import Camera, needed
from armtree.config.params import Param
from armtree.maths.motion.kinematics import KinematicModel
from armtree.maths.perception.frames import EYE_IN_HAND, tool_for_camera_over

from .actions import SkillFailure, fmt
from .base import Skill
from .reach import highest_reachable, nearest_reachable, reachable

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
    if needed(rig.camera, "camera").mount != EYE_IN_HAND:
        return point + UP * height
    return tool_under_camera(
        needed(rig.arm, "arm").model,
        needed(rig.camera, "camera"),
        np.asarray(needed(rig.arm, "arm").joints(), dtype=float),
        skill.clearance(),
        point,
        height,
        min_height,
    )


def tool_under_camera(
    model: KinematicModel,
    camera: Camera,
    q_near: np.ndarray,
    min_z: float | None,
    point: np.ndarray,
    height: float,
    min_height: float = 40.0,
) -> np.ndarray:
    """:func:`camera_over` for an arm at joints ``q_near`` (degrees) whose tool must stay at
    or above ``min_z`` (mm; None: no limit): a survey planned before anything moves."""
    if camera.mount != EYE_IN_HAND:
        return point + UP * height
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
        return tool_for_camera_over(model, point, h, camera.extrinsics, rotation_at=rotation_at)

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
    model = needed(skill.rig.arm, "arm").model
    if height <= 0 or reachable(model, want):
        return want
    best = highest_reachable(model, target, target[2], target[2] + height)
    return want if best is None else best


__all__ = ["UP", "ArmSkill", "above", "camera_over", "tool_under_camera"]
