"""Where the tool takes hold of an object: the grip point within reach, and the tool's kind.

Positions are the tool centre in the arm's base frame, mm.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from armtree import Param
from armtree.api.skill.arm import UP, ArmSkill
from armtree.api.skill.reach import lowest_reachable, reachable

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


__all__ = ["GRIP", "grip_point", "has_gripper"]
