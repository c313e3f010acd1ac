"""Picking a tagged object: find it with the camera, grip it clear of its neighbours,
check that it came with the tool.

Showers 2016 ("Loading a ducky"): the pump holds an object while the tool touches it.
The report's static ducky position needed frequent touch tests; here a place is only
where to look: :func:`~.locate.locate` finds the tag around it, and a pick the camera
contradicts (:mod:`.pick_check`) is a FAILURE with the measured numbers, which a retry
in the tree can act on. The grip goes to the release that follows on the blackboard
(:mod:`.held`). Tool centre and marker centres in the base frame, mm.
"""

from __future__ import annotations

import contextlib
from typing import Any

import numpy as np

from armtree import Param
from armtree.api.rig import needed
from armtree.api.skill.actions import ArmHome, Grip, Move, Pause, SkillFailure, fmt
from armtree.api.skill.arm import UP, ArmSkill, above
from armtree.api.skill.base import Procedure, as_list
from armtree.api.skill.eye import eye_of
from armtree.config.params import Binding

from .footprint import clear_grip, neighbours
from .grip import (
    GRIP,
    GRIP_HOLD,
    edge_toward_base,
    grip_point,
    has_gripper,
    tool_engaged,
    tool_pose_at,
)
from .held import HELD_KEY, Held, hand_over
from .locate import locate, skipped
from .pick_check import PickCheck


class Gripping(PickCheck):
    """A skill that grips: the shared grip, its check, and letting go of a failed grip."""

    GRASP = (
        Param(
            "approach_mm",
            "float",
            60.0,
            "mm",
            "height above the object to approach from and lift to",
            minimum=0.0,
            maximum=1000.0,
        ),
        Param("dwell_s", "float", 0.3, "s", "time for the tool to grip", minimum=0.0, maximum=60.0),
        Param(
            "verify", "bool", True, "", "check with the camera that the object came with the tool"
        ),
        Param(
            "verify_tolerance_mm",
            "float",
            10.0,
            "mm",
            "a marker this close to the pick spot was not picked",
            minimum=0.0,
            maximum=1000.0,
        ),
        Param(
            "skip",
            "any",
            None,
            "",
            "in/out: marker ids to leave alone; a failed one is added",
            io="inout",
        ),
        Param(
            "rehome_on_failure",
            "bool",
            False,
            "",
            "after a failed grip, home the arm on its own reference (missed steps undone)",
        ),
        Param("pose", "any", None, "mm", "output: where the object was picked", io="out"),
        *GRIP,
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm", "tool")

    def __init__(self, name: str, **params: Any) -> None:
        super().__init__(name, **params)
        hand_over(self.bb)

    def grip(self, target: np.ndarray, tag: str | None, marker: int | None) -> Procedure:
        """Grip at ``target`` and check the grip; a failure lets go on purpose and skips the marker."""
        try:
            spec = self.rig.tags.get(tag) if tag else None
            grip = yield from self.pick_steps(
                target,
                self.param("approach_mm"),
                self.workcell.grasp_offset_mm,
                self.param("dwell_s"),
                spec.size_mm if spec is not None else 0.0,
                self.marker_yaw(marker),
                marker,
            )
            if not tool_engaged(self.rig):
                raise SkillFailure(f"{self.name}: the tool reports it is not gripping")
            if not tag:
                self.feedback_message = self.unverified("no tag to check the grip with")
            elif self.rig.camera is None or self.rig.tracker is None:
                self.feedback_message = self.unverified("no camera to check the grip with")
            elif self.param("verify"):
                self.feedback_message = yield from self.verify_pick(
                    tag, marker, target, float(self.param("verify_tolerance_mm"))
                )
            if marker is not None:
                eye_of(self.rig).forget(marker)  # no longer where it stood
            self.hand_over(target, grip)
        except SkillFailure:
            if marker is not None:
                self.add_skip(marker)
            yield from self.let_go("the grip failed")
            if self.param("rehome_on_failure"):
                # a grip that missed may have missed because steps were lost: the next
                # try starts from joints the arm's own reference has set right
                self.note("rehome", why="the grip failed")
                home = ArmHome(self.rig)
                with contextlib.suppress(SkillFailure):
                    yield home
                if home.handle is not None:  # what the arm's homing did, in its words
                    self.note(
                        "rehomed", how=home.handle.description, status=home.handle.status.value
                    )
            raise
        self.output("pose", as_list(target))
        return target

    def pick_steps(
        self,
        target: np.ndarray,
        approach: float,
        grasp_offset: float,
        dwell: float,
        marker_size: float = 0.0,
        marker_yaw: float | None = None,
        marker: int | None = None,
    ) -> Procedure:
        """Approach above ``target``, descend, close the tool (suction on), let it grip, lift back.

        A marker ``marker_size`` mm wide whose centre is out of reach is touched nearer the
        arm's base on its face instead (suction cups only); ``marker_yaw`` (radians, its x
        axis in the base frame, as the camera saw it) says how far its edge lies that way.
        Before anything moves, the tool's boxes at the grip are checked against the objects
        the camera saw beside it (other than ``marker``'s, :mod:`.footprint`): a grip that
        would hit one moves within what still holds the object, else it fails (SkillFailure)
        naming what it would hit."""
        rig, speed = self.rig, self.speed()
        # a suction cup holds anywhere on the marker's face: up to 3 mm inside its edge
        edge = edge_toward_base(target, marker_size, marker_yaw)
        inward = 0.0 if has_gripper(rig) else max(0.0, edge - 3.0)
        grip = grip_point(self, target, grasp_offset, inward)
        # jaws closing on it hold an object gripped up to a fifth of its marker off centre
        hold = GRIP_HOLD * marker_size if has_gripper(rig) else max(0.0, 0.5 * marker_size - 3.0)
        grip = self.clear_of_neighbours(target, grip, grasp_offset, approach, marker, hold)
        over = above(self, grip - UP * grasp_offset, approach + grasp_offset)
        if has_gripper(rig):
            yield Grip(rig, False)  # a gripper opens before it goes down
        yield Move(rig, over, speed=speed, label="approach")
        yield Move(rig, grip, speed=speed, label="descend")
        yield Grip(rig, True)
        yield Pause(self.clock, dwell)
        yield Move(rig, over, speed=speed, label="lift")
        return grip

    def clear_of_neighbours(
        self,
        target: np.ndarray,
        grip: np.ndarray,
        grasp_offset: float,
        approach: float,
        marker: int | None,
        hold: float,
    ) -> np.ndarray:
        """``grip`` (mm), or a grip up to ``hold`` mm beside it whose tool boxes clear the
        objects the camera saw near ``target``; raises SkillFailure naming the object hit
        when none does. Logged as a ``footprint`` event when it had to act."""
        model = needed(self.rig.arm, "arm").model
        objects = neighbours(self, target, marker)
        if not objects:
            return grip
        over = above(self, grip - UP * grasp_offset, approach + grasp_offset)
        try:
            near = model.ik(over, near=needed(self.rig.arm, "arm").joints())
        except ValueError:  # the approach point is out of reach: the move will say so
            return grip
        found = clear_grip(model, grip, near, objects, hold)
        if not found.blocked_by:
            return grip
        what = ", ".join(
            f"the {o.role} (marker {o.id}) at {fmt(o.centre[:2])}" for o in found.blocked_by
        )
        if found.grip is None:
            self.note("footprint", refused=as_list(grip), hits=[o.id for o in found.blocked_by])
            raise SkillFailure(
                f"{self.name}: gripping at {fmt(grip)} would hit {what} "
                f"(the tool's boxes at the grip height), and no grip within {hold:.1f} mm "
                "beside it clears it"
            )
        self.note(
            "footprint",
            moved=as_list(found.grip),
            shift_mm=round(found.shift_mm, 1),
            hits=[o.id for o in found.blocked_by],
        )
        return found.grip

    def hand_over(self, target: np.ndarray, grip: np.ndarray) -> None:
        """Write the grip to the blackboard (:data:`~.held.HELD_KEY`) for the release that
        follows: where the marker at ``target`` sits on the tool gripping at ``grip`` (so
        the place check looks where it will land), and how far the object hangs below it."""
        in_tool = None
        with contextlib.suppress(ValueError):  # the grip point's IK (Unreachable)
            in_tool = np.linalg.inv(tool_pose_at(self.rig, grip)) @ np.append(target, 1.0)
        table = self.workcell.table_z_mm
        hang = None if table is None else float(grip[2] - table)
        self.bb.set(HELD_KEY, Held(in_tool, hang), overwrite=True)

    def marker_yaw(self, marker: int | None) -> float | None:
        """The heading (radians) of marker ``marker`` in the camera's last view, if it is there."""
        view = eye_of(self.rig).last
        seen = None if view is None else next((s for s in view.sightings if s.id == marker), None)
        if marker is None or seen is None:
            return None
        return float(np.arctan2(seen.pose[1, 0], seen.pose[0, 0]))

    def add_skip(self, marker: int) -> None:
        """Add ``marker`` to the ``skip`` list on the blackboard."""
        if isinstance(self.params.get("skip"), Binding):
            self.output("skip", sorted({*skipped(self.param("skip")), int(marker)}))

    def let_go(self, why: str) -> Procedure:
        """Open the tool on purpose (logged), so a failed grip leaves nothing half held."""
        if not tool_engaged(self.rig):
            return
        self.note("released", why=why)
        with contextlib.suppress(SkillFailure):
            yield Grip(self.rig, False)


class Pick(Gripping):
    """Pick a tagged object after finding it with the camera; check it came with the tool.

    ``tag``: the camera looks for that tag role around ``from`` (a place, a pose
    or a ``{key}``; anywhere in view without it) within the profile's
    ``workcell.search_radius_mm``, looking around when it is not over the hint,
    and measures it again from above before gripping. Not seen: FAILURE naming
    where it looked, and nothing moves down. After the lift the grip is checked
    (module docstring). ``at``: the explicit choice to pick an untagged object at
    a fixed place, blind; that pick is reported unverified.
    Writes ``pose`` (where the marker was gripped, mm); a marker it failed on (or
    ``marker``, the one a condition saw, when it is not found) is added to ``skip``
    so a reactive tree can leave it.
    """

    PARAMS = (
        Param(
            "tag",
            "str",
            "",
            "",
            "tag role of the object, looked for with the camera",
            kind="tag_role",
        ),
        Param(
            "from",
            "any",
            None,
            "mm",
            "place name, [x, y, z] or {key}: where to look for the tag (none: anywhere in view)",
            kind="place",
        ),
        Param(
            "at",
            "any",
            None,
            "mm",
            "untagged pick: place name, [x, y, z] or {key} where the object is gripped, blind",
            kind="place",
        ),
        Param(
            "marker",
            "any",
            None,
            "",
            "the marker id a condition saw (a {key}), skipped if not found",
        ),
        *Gripping.GRASP,
    )

    def __init__(self, name: str, **params: Any) -> None:
        super().__init__(name, **params)
        tag, source, at = params.get("tag"), params.get("from"), params.get("at")
        if at is not None and (tag or source is not None):
            raise ValueError(
                "give either tag (with from: where to look for it) or at (an untagged object "
                "picked blind at a fixed place), not both"
            )
        if at is None and not tag:
            raise ValueError(
                "give tag (the object's tag role, found with the camera; from: where to look) "
                "or, for an untagged object, at: the place to pick it blind"
            )

    def procedure(self) -> Procedure:
        if self.params.get("at") is not None:
            target = self.point(self.param("at"), f"{self.name}: at")
            return (yield from self.grip(target, None, None))
        tag = self.param("tag")
        if self.rig.camera is None or self.rig.tracker is None:
            raise SkillFailure(
                f"{self.name}: finding the {tag!r} tag needs a camera; "
                "pick an untagged object at a fixed place with at:"
            )
        source = self.param("from")
        hint = None if source is None else self.point(source, f"{self.name}: from")
        radius = self.workcell.search_radius_mm
        found = yield from locate(self, tag, hint, radius, skip=skipped(self.param("skip")))
        if found.sighting is None:
            expected = self.param("marker")
            if expected is not None:
                self.add_skip(int(expected))
            where = f"within {radius:g} mm of {fmt(hint)}" if hint is not None else "in view"
            raise SkillFailure(f"{self.name}: no {tag!r} tag {where} ({found.not_found(self.rig)})")
        self.feedback_message = f"{tag!r} tag at {fmt(found.position)}"
        return (yield from self.grip(found.position, tag, found.sighting.id))


class Grasp(Gripping):
    """Grip the object at ``at`` (usually a ``{key}`` a look wrote): approach, descend,
    close the tool, lift, and check the grip with the camera when ``tag`` is given.

    The fine-grained half of ``pick``: it does not look for the object first.
    """

    PARAMS = (
        Param(
            "at",
            "any",
            doc="place name, [x, y, z] or {key}: the object's marker (mm)",
            unit="mm",
            kind="place",
        ),
        Param("tag", "str", "", "", "tag role of the object, to check the grip", kind="tag_role"),
        Param("marker", "any", None, "", "its marker id (a {key}), skipped when the grip fails"),
        *Gripping.GRASP,
    )

    def procedure(self) -> Procedure:
        target = self.point(self.param("at"), f"{self.name}: at")
        marker = self.param("marker")
        return (
            yield from self.grip(target, self.param("tag"), None if marker is None else int(marker))
        )


__all__ = ["Grasp", "Gripping", "Pick"]
