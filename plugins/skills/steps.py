"""Fine-grained actions trees compose: look, approach, sweep and search_step.

``pick`` = ``look`` + ``grasp``, ``place`` = ``look`` + ``release``, ``search`` =
``sweep`` with conditions above it (see the shipped trees). Each is RUNNING
while its motion or look is under way and says in its feedback what it does.
Positions mm, base frame.

| node | does | SUCCESS / FAILURE | writes |
| --- | --- | --- | --- |
| ``look`` | finds ``tag`` around ``near`` (:func:`~.locate.locate`), measuring it again from above | seen / not seen, saying where it looked | ``pose``, ``marker`` |
| ``approach`` | tool ``height_mm`` above ``to`` (as high as the arm reaches) | arrived / refused | |
| ``sweep`` | camera over each point of ``workcell.survey`` in turn, looking for ``tag`` | seen / every point looked at | ``pose``, ``marker`` |
| ``search_step`` | the next ``steps`` points of the same sweep | seen / not in those | ``pose``, ``marker`` |

A sweep halted (preempted by a branch above it: trash to clear) keeps its place
and, ticked again, goes back to the point it was at and goes on from there
(Showers 2016, appendix B: the arm "will return to its previous position and
continue the searching process").
"""

from __future__ import annotations

import contextlib
from typing import Any

import numpy as np

from armtree import Param
from armtree.api.rig import needed
from armtree.api.skill.actions import Look, Move, SkillFailure, fmt
from armtree.api.skill.arm import ArmSkill, above, camera_over
from armtree.api.skill.base import Procedure, as_list
from armtree.api.skill.survey import survey_points

from .locate import locate, nearest, skipped
from .search import SCAN_PARAMS

#: Outputs of the actions that find a marker.
FOUND = (
    Param("pose", "any", None, "mm", "output: the marker's position [x, y, z]", io="out"),
    Param("marker", "any", None, "", "output: the marker's id", io="out"),
)


class LookFor(ArmSkill):
    """Find tag role ``tag`` around ``near`` with the camera and measure it from above.

    ``near`` is a place, a pose or a ``{key}`` (none: from where the camera is).
    Looks around within ``workcell.search_radius_mm`` when it is not over the hint;
    FAILURE naming where it looked when the tag is not seen. A fresh look before a
    retried grip is this node.
    """

    PARAMS = (
        Param("tag", "str", doc="tag role to find", kind="tag_role"),
        Param(
            "near",
            "any",
            None,
            "mm",
            "place name, [x, y, z] or {key}: where to look around (none: in view)",
            kind="place",
        ),
        Param("skip", "any", None, "", "marker ids to leave out (a {key} list)"),
        *FOUND,
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm",)
    NEEDS = ("arm", "camera")

    def procedure(self) -> Procedure:
        tag = self.param("tag")
        source = self.param("near")
        hint = None if source is None else self.point(source, f"{self.name}: near")
        radius = self.workcell.search_radius_mm
        found = yield from locate(self, tag, hint, radius, skip=skipped(self.param("skip")))
        if found.sighting is None:
            where = f"within {radius:g} mm of {fmt(hint)}" if hint is not None else "in view"
            raise SkillFailure(f"{self.name}: no {tag!r} tag {where} ({found.not_found(self.rig)})")
        self.output("pose", as_list(found.position))
        self.output("marker", int(found.sighting.id))
        self.feedback_message = f"{tag!r} marker {found.sighting.id} at {fmt(found.position)}"
        return found.position


class Approach(ArmSkill):
    """Bring the tool ``height_mm`` above ``to`` (a place, a pose or a ``{key}``), or as
    high above it as the arm reaches."""

    PARAMS = (
        Param(
            "to",
            "any",
            doc="place name, [x, y, z] or {key}: the point to hover over",
            unit="mm",
            kind="place",
        ),
        Param(
            "height_mm",
            "float",
            60.0,
            "mm",
            "tool height above the point",
            minimum=0.0,
            maximum=1000.0,
        ),
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm",)

    def procedure(self) -> Procedure:
        target = self.point(self.param("to"), f"{self.name}: to")
        over = above(self, target, float(self.param("height_mm")))
        yield Move(self.rig, over, speed=self.speed(), label="approach")
        self.feedback_message = f"{over[2] - target[2]:.0f} mm above {fmt(target)}"
        return over


class Sweep(ArmSkill):
    """Bring the camera over each point of the profile's ``workcell.survey`` region in
    turn and look for tag role ``tag``; SUCCESS when seen (``pose``, ``marker``).

    ``sweeps`` legs back and forth (a ring from the tool's heading, Showers 2016
    appendix B). Without ``tag`` the sweep just covers the region and succeeds at
    its end; with one, the end of the last leg is FAILURE. Halted, it keeps its
    place (module docstring).
    """

    PARAMS: tuple[Param, ...] = (
        Param(
            "tag", "str", "", "", "tag role to look for (empty: cover the region)", kind="tag_role"
        ),
        *SCAN_PARAMS,
        Param("skip", "any", None, "", "marker ids to leave out (a {key} list)"),
        *FOUND,
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm",)
    NEEDS = ("arm", "camera")
    WORKCELL = ("survey", "table_z_mm")

    def __init__(self, name: str, **params: Any) -> None:
        super().__init__(name, **params)
        self._points: list[np.ndarray] = []
        self._next = 0
        self._looked = 0

    def setup(self, **kwargs: Any) -> None:
        """Plan the first sweep from where the arm stands when the run starts, so a branch
        that moves the arm before the sweep's first tick (trash to clear) does not move
        its start."""
        super().setup(**kwargs)
        self.restart()
        if self.has_rig and self.rig.arm is not None and self.workcell.survey is not None:
            with contextlib.suppress(KeyError):  # a {sweeps} not on the blackboard yet
                self.plan()

    def restart(self) -> None:
        """Forget the sweep: the next run starts anew from the tool's heading."""
        self._points = []
        self._next = 0
        self._looked = 0

    def plan(self) -> None:
        """The table points of the whole sweep, from where the tool is now."""
        cell = self.workcell
        here = needed(self.rig.arm, "arm").pose()[:3, 3]
        survey = cell.need("survey", self.name)
        table_z = float(cell.need("table_z_mm", self.name))
        self._points = survey_points(survey, table_z, here, int(self.param("sweeps")))
        self._next = 0
        self._looked = 0

    def steps(self) -> int:
        """Scan poses to visit in this run (0: to the end of the sweep)."""
        return 0

    def procedure(self) -> Procedure:
        if not self._points:
            self.plan()
        tag = self.param("tag")
        skip = skipped(self.param("skip"))
        cell = self.workcell
        budget = self.steps()
        visited = 0
        refused = 0
        while self._next < len(self._points):
            point = self._points[self._next]
            pose = camera_over(self, point, cell.look_height_mm)
            self.feedback_message = f"scan pose {self._next + 1} of {len(self._points)}"
            try:
                yield Move(self.rig, pose, speed=self.speed(), label="scan")
            except SkillFailure:
                refused += 1
            else:
                sightings = yield Look(
                    self.rig,
                    self.clock,
                    want=tag or None,
                    frames=int(self.param("frames")),
                    settle=self.settle(),
                )
                self._looked += 1
                seen = nearest(sightings, tag, None, skip=skip) if tag else None
                if seen is not None:
                    self.restart()
                    self.output("pose", as_list(seen.position))
                    self.output("marker", int(seen.id))
                    self.feedback_message = f"{tag!r} marker {seen.id} at {fmt(seen.position)}"
                    return seen.position
            self._next += 1
            visited += 1
            if budget and visited >= budget and self._next < len(self._points):
                raise SkillFailure(f"{self.name}: no {tag!r} tag from scan pose {self._next}")
        looked, total = self._looked, len(self._points)
        self.restart()
        if not tag:
            self.feedback_message = f"covered the survey region from {looked} scan poses"
            return None
        detail = f"; {refused} refused" if refused else ""
        raise SkillFailure(
            f"{self.name}: no {tag!r} tag seen from {looked} of {total} scan poses{detail}"
        )


class SearchStep(Sweep):
    """The next ``steps`` scan poses of a ``sweep`` (kept between runs): SUCCESS when
    ``tag`` is seen from one of them, FAILURE when not (the next run goes on from
    there; after the last leg it starts again)."""

    PARAMS = (
        *Sweep.PARAMS,
        Param("steps", "int", 1, "", "scan poses per run", minimum=1, maximum=1000),
    )

    def steps(self) -> int:
        return int(self.param("steps"))


__all__ = ["Approach", "LookFor", "SearchStep", "Sweep"]
