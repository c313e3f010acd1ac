"""Checking a grip with the camera: did the marker leave its spot with the tool?

Eye-in-hand: the camera looks back at the spot, and a marker still lying there failed
the grip. Eye-to-hand: the marker must have risen with the tool (Durovic 2017's set-up sees
tool and object in one view), or, hidden under the gripper, be gone from the spot once
the arm has carried it out of the view. A failed check raises
:class:`~armtree.api.skill.actions.SkillFailure` with the measured numbers; each check
made is a ``check`` event in the run log. Marker centres in the base frame, mm.
"""

from __future__ import annotations

import numpy as np

from armtree.api.rig import needed
from armtree.api.skill.actions import Look, SkillFailure, fmt
from armtree.api.skill.arm import ArmSkill
from armtree.api.skill.base import Procedure, as_list
from armtree.maths.perception.frames import EYE_IN_HAND

from .locate import look_over, move_out_of_view, nearest

#: A marker this much higher than the spot it was gripped at has risen with the tool (mm).
RISEN_MM = 10.0


class PickCheck(ArmSkill):
    """An arm skill that checks with the camera that a grip took its object."""

    def verify_pick(
        self,
        tag: str,
        marker: int | None,
        spot: np.ndarray,
        tolerance: float,
        looked_away: bool = False,
    ) -> Procedure:
        """Check with the camera that marker ``marker`` (role ``tag``; None: the one of that
        role nearest ``spot``) left ``spot`` with the tool.

        Raises :class:`SkillFailure` with the measured distances when it did not;
        returns a one-line description of what was checked.
        """
        rig = self.rig
        in_hand = needed(rig.camera, "camera").mount == EYE_IN_HAND
        if in_hand:
            after = yield from look_over(self, spot, self.workcell.look_height_mm, None, 2)
        else:
            after = yield Look(rig, self.clock, frames=2, settle=self.settle())
        if marker is None:
            mine = nearest(after, tag, spot, 4.0 * tolerance)
        else:
            mine = next((s for s in after if s.id == marker), None)
        if mine is not None:
            off = mine.position - spot
            flat, rise = float(np.linalg.norm(off[:2])), float(off[2])
            if flat < tolerance and abs(rise) < tolerance:
                self.note("check", check="pick", ok=False, tag=tag, offset_mm=as_list(off))
                raise SkillFailure(
                    f"{self.name}: the {tag!r} tag is still at {fmt(mine.position)}, "
                    f"{flat:.1f} mm from where it was gripped: the grip failed"
                )
            if not in_hand:
                tool = needed(rig.arm, "arm").pose()[:3, 3]
                to_tool = float(np.linalg.norm(mine.position[:2] - tool[:2]))
                if rise < RISEN_MM or to_tool > 2.0 * tolerance:
                    self.note("check", check="pick", ok=False, tag=tag, offset_mm=as_list(off))
                    raise SkillFailure(
                        f"{self.name}: the {tag!r} tag is at {fmt(mine.position)}, {rise:.1f} mm "
                        f"above the spot and {to_tool:.1f} mm beside the tool: it did not come with it"
                    )
                self.note("check", check="pick", ok=True, tag=tag, rise_mm=round(rise, 1))
                return f"the tag rose {rise:.0f} mm with the tool"
        if not in_hand and not looked_away:
            # hidden under the tool, or the arm hides the spot: carry it out of the view, look again
            yield from move_out_of_view(self, spot)
            return (yield from self.verify_pick(tag, marker, spot, tolerance, looked_away=True))
        self.note("check", check="pick", ok=True, tag=tag, how="spot looked at, tag gone")
        return "the spot is empty"


__all__ = ["RISEN_MM", "PickCheck"]
