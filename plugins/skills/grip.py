"""Where the tool takes hold of an object: the grip point within reach, the tool's kind
and whether it grips, and where a gripped marker sits on the tool.

Positions are the tool centre in the arm's base frame, mm.
"""

from __future__ import annotations

import numpy as np

from armtree import Param
from armtree.api.rig import Rig, needed
from armtree.api.skill.arm import UP, ArmSkill
from armtree.api.skill.reach import lowest_reachable, reachable

#: A gripper's jaws still hold an object gripped this fraction of its marker's side off centre.
GRIP_HOLD = 0.2
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


def has_gripper(rig: Rig) -> bool:
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
    model = needed(skill.rig.arm, "arm").model
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


def edge_toward_base(target: np.ndarray, size: float, yaw: float | None) -> float:
    """Distance (mm) from a ``size`` mm marker's centre at ``target`` to its edge in the
    direction of the arm's base: half its size across its sides, more across a corner;
    half its size when its heading ``yaw`` (radians) is unknown."""
    half = 0.5 * size
    if yaw is None or np.hypot(target[0], target[1]) < 1e-6:
        return half
    angle = np.arctan2(-target[1], -target[0]) - yaw
    return float(half / max(abs(np.cos(angle)), abs(np.sin(angle))))


def tool_pose_at(rig: Rig, xyz: np.ndarray) -> np.ndarray:
    """The tool's pose (4x4) with its centre at ``xyz``, as the arm's model reaches it."""
    assert rig.arm is not None, "gripping skills run on rigs with an arm"
    model = rig.arm.model
    return model.fk(model.ik(np.asarray(xyz, dtype=float), near=rig.arm.joints()))


def tool_engaged(rig: Rig) -> bool:
    """True when the rig's tool reports gripping (``rig.tool.holding``: suction on, a gripper
    nearer closed than open); False for a rig without one."""
    tool = getattr(rig, "tool", None)
    return tool is not None and bool(tool.holding)


__all__ = [
    "GRIP",
    "GRIP_HOLD",
    "edge_toward_base",
    "grip_point",
    "has_gripper",
    "tool_engaged",
    "tool_pose_at",
]
