"""Plain motions: go to a place or a pose, go home."""

from __future__ import annotations

import numpy as np

from armtree import Param
from armtree.api.rig import needed
from armtree.api.skill.actions import ArmHome, Move
from armtree.api.skill.arm import ArmSkill
from armtree.api.skill.base import Procedure, as_list


class MoveTo(ArmSkill):
    """Move the tool to a place, an [x, y, z] pose (mm) or a {key}, through the planner."""

    PARAMS = (
        Param(
            "to",
            "any",
            doc="place name, [x, y, z] or {key}: where the tool centre goes",
            unit="mm",
            kind="place",
        ),
        Param(
            "offset",
            "vector",
            [0.0, 0.0, 0.0],
            "mm",
            "added to the target, e.g. [0, 0, 50] to hover",
            minimum=-5000.0,
            maximum=5000.0,
            length=3,
        ),
        Param("pose", "any", None, "mm", "output: the position reached", io="out"),
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm",)

    def procedure(self) -> Procedure:
        target = self.point(self.param("to"), f"{self.name}: to") + np.asarray(
            self.param("offset"), dtype=float
        )
        yield Move(self.rig, target, speed=self.speed(), label="move")
        self.output("pose", as_list(target))
        return target


class Home(ArmSkill):
    """Move the arm to its model's home joint configuration, through the planner.

    With ``reference`` the arm homes the way its firmware does (``ArmDriver.home``:
    on its end stops where it has them, as the VICRA's G28), so steps it missed are
    undone: a retry after a grip the camera saw fail starts from true joints.
    """

    PARAMS = (
        Param(
            "reference",
            "bool",
            False,
            "",
            "home with the arm's own homing (end stops) to undo missed steps",
        ),
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm",)

    def procedure(self) -> Procedure:
        home = np.asarray(needed(self.rig.arm, "arm").model.home, dtype=float)
        if self.param("reference"):
            yield ArmHome(self.rig)
            return home
        yield Move(self.rig, joints=home, speed=self.speed(), label="home")
        return home
