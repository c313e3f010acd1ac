"""Conditions a reactive tree checks every tick: instant, never moving anything.

Each returns SUCCESS or FAILURE in the tick it is ticked (never RUNNING), and says
why in its feedback. The camera conditions read the rig's :class:`~.eye.Eye`:
a view at most ``max_age_s`` old is reused, so a selector re-checking them every
tick costs a few frames a second, not twenty. Positions in mm, base frame.

| node | SUCCESS when | writes |
| --- | --- | --- |
| ``tag_visible`` | a marker of ``tag`` is in the newest view (not in ``skip``, not near ``ignore_near``) | ``pose`` [x, y, z], ``marker`` id |
| ``tag_near`` | a marker of ``tag`` is within ``radius_mm`` of ``near`` | ``pose``, ``marker`` |
| ``misplaced`` | a marker is seen away from the place ``workcell.sort`` gives its role | ``pose``, ``marker``, ``role``, ``place`` |
| ``holding`` | the tool reports gripping (and, eye-to-hand, ``tag`` is not seen away from the tool) | |
| ``at_place`` | the tool centre is within ``tolerance_mm`` of ``place`` | |
| ``arm_idle`` | no running behaviour owns the arm | |
"""

from __future__ import annotations

from typing import Any

import numpy as np
from py_trees.common import Status

from armtree import Param
from armtree.api.rig import needed
from armtree.api.skill.actions import SkillFailure, fmt
from armtree.api.skill.base import Skill, as_list
from armtree.api.skill.eye import Sighting, eye_of
from armtree.maths.perception.frames import EYE_IN_HAND

from .grip import tool_engaged
from .locate import skipped


class Condition(Skill):
    """A check made within one tick: :meth:`check` returns (holds, why)."""

    CONDITION = True
    NEEDS: tuple[str, ...] = ()

    def check(self) -> tuple[bool, str]:
        """Whether the condition holds now, and a few words why."""
        raise NotImplementedError

    def initialise(self) -> None:
        self.feedback_message = ""

    def update(self) -> Status:
        for part in self.NEEDS:
            if getattr(self.rig, part, None) is None:
                self.feedback_message = f"{self.name}: this rig has no {part}"
                return Status.FAILURE
        try:
            holds, why = self.check()
        except SkillFailure as exc:
            holds, why = False, str(exc)
        self.feedback_message = why
        return Status.SUCCESS if holds else Status.FAILURE

    def terminate(self, new_status: Status) -> None:
        return None


class _Seeing(Condition):
    """A condition on the markers in the camera's newest view."""

    NEEDS = ("camera", "tracker")
    COMMON = (
        Param(
            "max_age_s",
            "float",
            0.3,
            "s",
            "reuse a view this recent instead of reading a new frame",
            minimum=0.0,
            maximum=60.0,
        ),
        Param("skip", "any", None, "", "marker ids to leave out (a {key} list)"),
        Param("pose", "any", None, "mm", "output: the marker's position [x, y, z]", io="out"),
        Param("marker", "any", None, "", "output: the marker's id", io="out"),
    )

    def seen(self) -> list[Sighting]:
        """The sightings of ``tag`` in a recent view, without skipped markers."""
        view = eye_of(self.rig).recent(float(self.param("max_age_s")))
        if view is None:
            return []
        skip = set(skipped(self.param("skip")))
        return [s for s in view.of(self.param("tag")) if s.id not in skip]

    def found(self, sighting: Sighting) -> tuple[bool, str]:
        """Write ``sighting`` to the outputs; the condition holds."""
        self.output("pose", as_list(sighting.position))
        self.output("marker", int(sighting.id))
        return True, f"{sighting.role!r} marker {sighting.id} at {fmt(sighting.position)}"

    def nearest_to_tool(self, sightings: list[Sighting]) -> Sighting:
        """The sighting nearest the tool (cheapest to reach), in the xy plane."""
        tool = self.rig.arm.pose()[:3, 3] if self.rig.arm is not None else np.zeros(3)
        return min(sightings, key=lambda s: float(np.linalg.norm(s.position[:2] - tool[:2])))


class TagVisible(_Seeing):
    """SUCCESS when a marker of role ``tag`` is in the camera's newest view.

    ``ignore_near`` (a place) leaves out markers within ``ignore_radius_mm`` of it
    (trash already over the bin); ``skip`` leaves out marker ids (a {key} list a
    failed ``pick`` adds to). Of several, the one nearest the tool is written to
    ``pose`` and ``marker``.
    """

    PARAMS = (
        Param("tag", "str", doc="tag role to look for", kind="tag_role"),
        Param(
            "ignore_near",
            "any",
            None,
            "mm",
            "place name, [x, y, z] or {key}: markers near it do not count",
            kind="place",
        ),
        Param(
            "ignore_radius_mm",
            "float",
            60.0,
            "mm",
            "how near `ignore_near` a marker is left out",
            minimum=0.0,
            maximum=5000.0,
        ),
        *_Seeing.COMMON,
    )

    def check(self) -> tuple[bool, str]:
        sightings = self.seen()
        near = self.param("ignore_near")
        if near is not None:
            spot = self.point(near, f"{self.name}: ignore_near")
            radius = float(self.param("ignore_radius_mm"))
            sightings = [s for s in sightings if np.linalg.norm(s.position[:2] - spot[:2]) > radius]
        if not sightings:
            return False, f"no {self.param('tag')!r} tag in view"
        return self.found(self.nearest_to_tool(sightings))


class TagNear(_Seeing):
    """SUCCESS when a marker of role ``tag`` is within ``radius_mm`` of ``near`` (in the xy plane)."""

    PARAMS = (
        Param("tag", "str", doc="tag role to look for", kind="tag_role"),
        Param(
            "near",
            "any",
            doc="place name, [x, y, z] or {key}: where the marker should be",
            unit="mm",
            kind="place",
        ),
        Param(
            "radius_mm",
            "float",
            0.0,
            "mm",
            "how far from `near` (0: the profile's workcell.search_radius_mm)",
            minimum=0.0,
            maximum=5000.0,
        ),
        *_Seeing.COMMON,
    )

    def check(self) -> tuple[bool, str]:
        spot = self.point(self.param("near"), f"{self.name}: near")
        radius = float(self.param("radius_mm")) or self.workcell.search_radius_mm
        close = [s for s in self.seen() if np.linalg.norm(s.position[:2] - spot[:2]) <= radius]
        if not close:
            return False, f"no {self.param('tag')!r} tag within {radius:g} mm of {fmt(spot)}"
        return self.found(
            min(close, key=lambda s: float(np.linalg.norm(s.position[:2] - spot[:2])))
        )


class Misplaced(_Seeing):
    """SUCCESS when a marker whose role the profile's ``workcell.sort`` gives a place is
    seen more than ``radius_mm`` from that place; writes it (nearest the tool first)
    to ``pose``, ``marker``, ``role`` and ``place`` (the place's name)."""

    PARAMS = (
        Param(
            "radius_mm",
            "float",
            60.0,
            "mm",
            "a marker this near its place is where it belongs",
            minimum=0.0,
            maximum=5000.0,
        ),
        *_Seeing.COMMON,
        Param("role", "any", None, "", "output: the marker's tag role", io="out"),
        Param("place", "any", None, "", "output: the name of the place it belongs", io="out"),
    )

    def check(self) -> tuple[bool, str]:
        sort = self.workcell.sort
        view = eye_of(self.rig).recent(float(self.param("max_age_s")))
        skip = set(skipped(self.param("skip")))
        radius = float(self.param("radius_mm"))
        stray: list[Sighting] = []
        for s in [] if view is None else view.sightings:
            if s.role not in sort or s.id in skip or sort[s.role] not in self.rig.places:
                continue
            home = np.asarray(self.rig.places[sort[s.role]], dtype=float)
            if np.linalg.norm(s.position[:2] - home[:2]) > radius:
                stray.append(s)
        if not stray:
            return False, "nothing out of place in view"
        best = self.nearest_to_tool(stray)
        self.output("role", best.role)
        self.output("place", sort[best.role])
        holds, why = self.found(best)
        return holds, f"{why} belongs at {sort[best.role]}"


class Holding(Condition):
    """SUCCESS when the tool reports gripping (suction on, gripper closed).

    Eye-to-hand with ``tag``: FAILURE as well when that marker is seen more than
    ``tolerance_mm`` from the tool (it fell). Eye-in-hand the camera cannot see
    under the tool: the feedback says the tool's report is all there is.
    """

    NEEDS = ("arm",)
    PARAMS = (
        Param("tag", "str", "", "", "tag role of the object that should be held", kind="tag_role"),
        Param(
            "tolerance_mm",
            "float",
            40.0,
            "mm",
            "a held marker is at most this far from the tool centre",
            minimum=0.0,
            maximum=1000.0,
        ),
        Param(
            "max_age_s",
            "float",
            0.3,
            "s",
            "reuse a view this recent",
            minimum=0.0,
            maximum=60.0,
        ),
    )

    def check(self) -> tuple[bool, str]:
        if not tool_engaged(self.rig):
            return False, "the tool is not gripping"
        tag, camera = self.param("tag"), self.rig.camera
        if not tag or camera is None or self.rig.tracker is None or camera.mount == EYE_IN_HAND:
            return True, "the tool reports gripping (not seen: the camera cannot look under it)"
        view = eye_of(self.rig).recent(float(self.param("max_age_s")))
        tool = needed(self.rig.arm, "arm").pose()[:3, 3]
        for s in [] if view is None else view.of(tag):
            away = float(np.linalg.norm(s.position - tool))
            if away > float(self.param("tolerance_mm")):
                return (
                    False,
                    f"the {tag!r} tag is at {fmt(s.position)}, {away:.0f} mm from the tool",
                )
        return True, "the tool reports gripping"


class AtPlace(Condition):
    """SUCCESS when the tool centre is within ``tolerance_mm`` of ``place`` (from the joint readings)."""

    NEEDS = ("arm",)
    PARAMS = (
        Param(
            "place",
            "any",
            doc="place name, [x, y, z] or {key}",
            unit="mm",
            kind="place",
        ),
        Param("tolerance_mm", "float", 5.0, "mm", "how near counts", minimum=0.0, maximum=1000.0),
    )

    def check(self) -> tuple[bool, str]:
        place = self.point(self.param("place"), f"{self.name}: place")
        tool = needed(self.rig.arm, "arm").pose()[:3, 3]
        away = float(np.linalg.norm(tool - place))
        holds = away <= float(self.param("tolerance_mm"))
        return holds, f"the tool is {away:.1f} mm from {fmt(place)}"


class ArmIdle(Condition):
    """SUCCESS when no running behaviour owns the arm (nothing is moving it)."""

    def check(self) -> tuple[bool, str]:
        resources: Any = getattr(self.runtime, "resources", None)
        owner = None if resources is None else resources.owner("arm")
        if owner is None:
            return True, "the arm is idle"
        return False, f"{owner.name} has the arm"


__all__ = ["ArmIdle", "AtPlace", "Condition", "Holding", "Misplaced", "TagNear", "TagVisible"]
