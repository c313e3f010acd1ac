"""Checking a release with the camera: where did the held object go?

After letting go the held object's marker must lie on the target within the
tolerance (on a marker) or near the place (a bin may hide it). Eye-to-hand, before
descending, the held marker must ride where the grip left it on the tool; joints that
lost steps move the release instead. A check the rig cannot make is said in the
feedback and written as an ``unverified`` event, never claimed. Base frame, mm.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from armtree.api.rig import needed
from armtree.api.skill.actions import Look, SkillFailure, fmt
from armtree.api.skill.arm import UP, ArmSkill
from armtree.api.skill.base import Procedure, as_list
from armtree.api.skill.eye import eye_of
from armtree.api.skill.reach import reachable
from armtree.maths.perception.frames import EYE_IN_HAND

from .locate import look_over, move_out_of_view, nearest

#: An object put on a target marker rests at least this much above it (mm).
ON_TOP_MM = 5.0
#: Steps of the look around a place the check did not see the object at, as a fraction
#: of the camera's view on the table.
CHECK_STEP = 0.3
#: A held marker this far (mm) beside or below where the arm's joints put it moves the
#: release; one farther than the limit is not the held object's.
HELD_TOLERANCE_MM = 4.0
HELD_LIMIT_MM = 40.0


class PlaceCheck(ArmSkill):
    """An arm skill that checks with the camera where the object it let go went, and
    (eye-to-hand) that the held object rides where the grip left it (``object``: its tag
    role, a parameter of the skill)."""

    def verify_place(
        self,
        obj: str,
        target: np.ndarray,
        on_marker: bool,
        tolerance: float,
        marker: int | None = None,
        expected: np.ndarray | None = None,
    ) -> Procedure:
        """Check with the camera that an ``obj`` tag lies at ``target`` (on it when ``on_marker``).

        With ``marker`` only that marker id counts: another object of the same role
        (trash still on the table) is not the one let go.

        Raises :class:`SkillFailure` with the measured distance when it does not;
        returns a one-line description of what was checked.
        """
        rig = self.rig
        cell = self.workcell
        in_hand = needed(rig.camera, "camera").mount == EYE_IN_HAND
        limit = tolerance if on_marker else max(tolerance, cell.search_radius_mm)
        if in_hand:
            # over the target, then around it: a marker turned near the image's corner
            # over a small view is seen whole from a little aside
            seen = None
            # first where the object should have landed (its marker sat off the tool centre)
            first = target if expected is None else expected
            views: list[np.ndarray] = [first]
            while views and seen is None:
                point = views.pop(0)
                after = yield from look_over(self, point, cell.look_height_mm, obj, 2)
                seen = nearest([s for s in after if marker is None or s.id == marker], obj, target)
                if seen is None and point is first:
                    # an object let go a little aside (gripped off its marker's centre, let go
                    # where the arm reached) sits at the view's edge: look in small steps
                    view = eye_of(rig).last
                    size = None if view is None else view.footprint(float(target[2]))
                    step = CHECK_STEP * (min(size) if size else limit)
                    views = [
                        first + np.array([r * np.cos(a), r * np.sin(a), 0.0])
                        for r in (step, 2.0 * step)
                        for a in np.linspace(0.0, 2.0 * np.pi, 8, endpoint=False)
                    ]
        else:
            yield from move_out_of_view(self, target)
            after = yield Look(rig, self.clock, want=obj, frames=2, settle=self.settle())
            seen = nearest([s for s in after if marker is None or s.id == marker], obj, target)
        if seen is None:
            if in_hand and on_marker:
                self.note("check", check="place", ok=False, tag=obj, seen=False)
                raise SkillFailure(
                    f"{self.name}: no {obj!r} tag in view over {fmt(target)} or around it "
                    "after letting go"
                )
            return self.unverified(f"the {obj!r} tag is not in view after letting go")
        off = seen.position - target
        flat = float(np.linalg.norm(off[:2]))
        ok = flat <= limit and (not on_marker or off[2] >= ON_TOP_MM)
        self.note("check", check="place", ok=ok, tag=obj, offset_mm=as_list(off), limit_mm=limit)
        if not ok:
            where = "on" if on_marker else "at"
            raise SkillFailure(
                f"{self.name}: the {obj!r} tag is at {fmt(seen.position)}, {flat:.1f} mm from "
                f"{fmt(target)} and {off[2]:+.1f} mm above it: not {where} the target "
                f"(tolerance {limit:g} mm)"
            )
        return f"the {obj!r} tag is {flat:.0f} mm from the target"

    def check_held(self, point: np.ndarray, held: np.ndarray | None, marker: Any) -> Procedure:
        """Eye-to-hand, before descending to let go at ``point``: the held object's marker
        should ride where the grip left it on the tool (``held``); the fixed camera sees
        where it is. Joints that lost steps put it elsewhere, so the descent is moved by
        the disagreement beside the camera's ray and raised (never lowered) by how much
        lower it hangs; beyond :data:`HELD_LIMIT_MM` the release fails, still holding.
        Returns the point to descend to."""
        rig, obj = self.rig, self.param("object")
        if rig.camera is None or rig.tracker is None or rig.camera.mount == EYE_IN_HAND:
            return point
        if held is None or not obj:
            return point
        view = yield Look(rig, self.clock, want=obj, frames=3, settle=self.settle(), average=True)
        expected = (needed(rig.arm, "arm").pose() @ held)[:3]
        mine = [s for s in view if marker is None or s.id == int(marker)]
        seen = nearest(mine, obj, expected, HELD_LIMIT_MM)
        if seen is None:
            self.unverified(f"the held {obj!r} tag is not in view before letting go")
            return point
        off = seen.position - expected
        flat, low = float(np.linalg.norm(off[:2])), float(-off[2])
        ok = flat <= HELD_TOLERANCE_MM and low <= HELD_TOLERANCE_MM
        self.note("check", check="held", ok=ok, tag=obj, offset_mm=as_list(off))
        if ok:
            return point
        corrected = point - np.array([off[0], off[1], 0.0]) + UP * max(0.0, low)
        if not reachable(needed(rig.arm, "arm").model, corrected):
            raise SkillFailure(
                f"{self.name}: the held {obj!r} tag is at {fmt(seen.position)}, {flat:.1f} mm "
                f"beside and {low:.1f} mm below where the arm's joints put it, and the "
                f"corrected release {fmt(corrected)} is out of reach; still holding it"
            )
        self.note("corrected", why="held marker off the tool", point_mm=as_list(corrected))
        return corrected


__all__ = ["CHECK_STEP", "HELD_LIMIT_MM", "HELD_TOLERANCE_MM", "ON_TOP_MM", "PlaceCheck"]
