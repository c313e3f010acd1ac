"""Putting the held object down: on a target's marker found with the camera, at a place,
or across the inside of a bin, and checking with the camera where it went
(:mod:`.place_check`). Tool centre and marker centres in the base frame, mm.
"""

from __future__ import annotations

import contextlib
from typing import Any

import numpy as np

from armtree import Param
from armtree.api.skill.actions import SkillFailure, fmt
from armtree.api.skill.arm import UP, ArmSkill
from armtree.api.skill.base import Procedure, as_list
from armtree.api.skill.eye import eye_of

from .bin_drop import bin_drop
from .bins import Drop, remember_drop, share_bins
from .grip import tool_pose_at
from .held import take, take_over
from .locate import locate
from .place_check import PlaceCheck
from .release import release_at, release_steps


class PuttingDown(PlaceCheck):
    """A skill that lets go: the shared release and its check."""

    RELEASE = (
        Param(
            "object",
            "str",
            "",
            "",
            "tag role of the held object, to check where it went",
            kind="tag_role",
        ),
        Param(
            "approach_mm",
            "float",
            60.0,
            "mm",
            "height above the target to approach from",
            minimum=0.0,
            maximum=1000.0,
        ),
        Param(
            "dwell_s", "float", 0.3, "s", "time for the tool to let go", minimum=0.0, maximum=60.0
        ),
        Param("verify", "bool", True, "", "check with the camera where the object went"),
        Param(
            "marker",
            "any",
            None,
            "",
            "the held object's marker id (a {key}): the check follows it, not the nearest "
            "tag of its role",
        ),
        Param(
            "place_tolerance_mm",
            "float",
            20.0,
            "mm",
            "how far the object may rest from the target's marker",
            minimum=0.0,
            maximum=1000.0,
        ),
        Param("pose", "any", None, "mm", "output: where the object was released", io="out"),
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm", "tool")

    def __init__(self, name: str, **params: Any) -> None:
        super().__init__(name, **params)
        take_over(self.bb)  # the grip the pick before handed over
        share_bins(self.bb)

    def put_down(self, target: np.ndarray, on_marker: bool) -> Procedure:
        """Let go over ``target`` (``workcell.release_offset_mm`` above a marker, at a place
        itself, across the inside of a bin the profile's ``workcell.bins`` describes) and
        check where the object went."""
        release = self.workcell.release_offset_mm if on_marker else 0.0
        grip = take(self.bb)
        held = None if grip is None else grip.marker_in_tool
        hang = None if grip is None else grip.hang_mm
        bin_name = None if on_marker else self.bin_at()
        marker = self.param("marker")

        def check(point: np.ndarray) -> Procedure:
            return (yield from self.check_held(point, held, marker))

        if bin_name is not None and hang is not None:
            drop = self.plan_bin_drop(bin_name, target, held, hang)
            point = yield from release_at(
                self, drop.tool, max(0.0, self.param("approach_mm")), self.param("dwell_s"), check
            )
        else:
            point = yield from release_steps(
                self, target, self.param("approach_mm"), release, self.param("dwell_s"), check
            )
        released = target + UP * release
        expected = None
        if held is not None:
            with contextlib.suppress(ValueError):  # the release point's IK (Unreachable)
                landed = (tool_pose_at(self.rig, point) @ held)[:3]
                expected = np.array([landed[0], landed[1], target[2]])
        if bin_name is not None:
            # until the camera says otherwise it lies where it was let go, as high as that
            landing = point if expected is None else expected
            remember_drop(
                self.bb, bin_name, self.bin_key(marker), np.array([*landing[:2], point[2]])
            )
        self.output("pose", as_list(released))
        obj = self.param("object")
        if not self.param("verify"):
            return released
        if not obj:
            self.feedback_message = self.unverified("no `object` tag given to check where it went")
        elif self.rig.camera is None or self.rig.tracker is None:
            self.feedback_message = self.unverified("no camera to check where it went")
        else:
            self.feedback_message = yield from self.verify_place(
                obj,
                target,
                on_marker,
                float(self.param("place_tolerance_mm")),
                None if marker is None else int(marker),
                expected,
            )
            last = eye_of(self.rig).last
            if bin_name is not None and marker is not None and last is not None:
                seen = next((s for s in last.sightings if s.id == int(marker)), None)
                if seen is not None:
                    remember_drop(self.bb, bin_name, int(marker), seen.position)
        return released

    def bin_at(self) -> str | None:
        """The place ``at`` names when the profile describes a bin there, else None."""
        value = self.param("at")
        if isinstance(value, str) and value in self.workcell.bins:
            return value
        return None

    def bin_key(self, marker: Any) -> Any:
        """The key the held object is remembered by in a bin: its marker id, else a new one."""
        if marker is not None:
            return int(marker)
        return ("drop", self.name, self.clock.now())

    def plan_bin_drop(
        self, name: str, place: np.ndarray, held: np.ndarray | None, hang: float
    ) -> Drop:
        """Where to let go in the bin at place ``name`` (:func:`~.bin_drop.bin_drop`)."""
        marker = self.param("marker")
        return bin_drop(
            self,
            name,
            place,
            held,
            hang,
            self.param("object"),
            None if marker is None else int(marker),
        )


class Place(PuttingDown):
    """Put the held object down and check with the camera where it went.

    With ``tag`` the target's marker is found around ``at`` (a place, a pose or
    a ``{key}``) within ``workcell.search_radius_mm`` and measured again from
    above; not seen: FAILURE, nothing released (the object stays held). The tool
    lets go ``workcell.release_offset_mm`` above the marker. Without ``tag``,
    ``at`` is the release point itself (a bin, a drop spot). With ``object`` (the
    held object's tag role) the camera checks afterwards that it lies on the
    target within ``place_tolerance_mm`` (near the place without ``tag``).
    Writes ``pose``: where the tool let go (mm).
    """

    PARAMS = (
        Param(
            "at",
            "any",
            doc="place name, [x, y, z] or {key}: where to put the object, or to look for `tag`",
            unit="mm",
            kind="place",
        ),
        Param(
            "tag",
            "str",
            "",
            "",
            "tag role marking the target, found around `at` before letting go",
            kind="tag_role",
        ),
        *PuttingDown.RELEASE,
    )

    def procedure(self) -> Procedure:
        target = self.point(self.param("at"), f"{self.name}: at")
        tag = self.param("tag")
        if tag:
            if self.rig.camera is None or self.rig.tracker is None:
                raise SkillFailure(f"{self.name}: finding the {tag!r} tag needs a camera")
            radius = self.workcell.search_radius_mm
            found = yield from locate(self, tag, target, radius)
            if found.sighting is None:
                raise SkillFailure(
                    f"{self.name}: no {tag!r} tag within {radius:g} mm of {fmt(target)} "
                    f"({found.not_found(self.rig)}); still holding the object"
                )
            target = found.position
        return (yield from self.put_down(target, bool(tag)))


class Release(PuttingDown):
    """Let go of the held object over ``at`` and check where it went: the fine-grained
    half of ``place`` (it does not look for the target first). ``on_marker``: ``at``
    is a target's marker (a ``{key}`` a look wrote), so the tool lets go
    ``workcell.release_offset_mm`` above it; else ``at`` is the release point."""

    PARAMS = (
        Param(
            "at",
            "any",
            doc="place name, [x, y, z] or {key}: where to let go",
            unit="mm",
            kind="place",
        ),
        Param("on_marker", "bool", False, "", "`at` is a marker to put the object on"),
        *PuttingDown.RELEASE,
    )

    def procedure(self) -> Procedure:
        target = self.point(self.param("at"), f"{self.name}: at")
        return (yield from self.put_down(target, bool(self.param("on_marker"))))


__all__ = ["Place", "PuttingDown", "Release"]
