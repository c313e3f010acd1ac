"""Search the workspace for a tag, and clean up trash markers on the way (Showers 2016, appendix B).

The report's search turns the base in 5 degree steps, the other joints still,
reversing past 100 degrees either side; at each step it asks the camera for the
wanted tag, and in clean-up mode first carries any trash it sees to the
garbage bin and returns to where it was.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from armtree import Param
from armtree.api.rig import needed
from armtree.api.skill.actions import Grip, Look, Move, Pause, SkillFailure, fmt
from armtree.api.skill.arm import ArmSkill, above, camera_over
from armtree.api.skill.base import ActionFailed, Procedure, as_list
from armtree.api.skill.eye import Sighting, Tally
from armtree.api.skill.survey import survey_points

from .bin_drop import bin_drop
from .bins import remember_drop, share_bins
from .grip import GRIP, grip_point, has_gripper
from .release import release_at, release_steps


@dataclass
class TrashLog:
    """What clean-up did: carries made, attempts per marker id, markers given up and why."""

    carried: int = 0
    attempts: dict[int, int] = field(default_factory=dict)
    skipped: dict[int, str] = field(default_factory=dict)
    #: The marker of the last carry and where it was, to notice a carry that left it behind.
    last: tuple[int, np.ndarray] | None = None

    def check(self, sightings: list[Sighting], tolerance: float = 15.0) -> None:
        """Un-count the last carry if its marker is still where it was."""
        if self.last is None:
            return
        mid, where = self.last
        self.last = None
        if any(s.id == mid and np.linalg.norm(s.position - where) < tolerance for s in sightings):
            self.carried -= 1

    def summary(self) -> str:
        """One line for feedback messages."""
        text = f"{self.carried} trash carried to the bin"
        if self.skipped:
            why = "; ".join(f"marker {k}: {v}" for k, v in self.skipped.items())
            text += f", {len(self.skipped)} left ({why})"
        return text


def clean_one(
    skill: ArmSkill, item: Sighting, origin: np.ndarray, bin_xyz: np.ndarray, log: TrashLog
) -> Procedure:
    """Carry one trash marker to the bin and come back to ``origin``.

    Trash the arm cannot get to (a refused approach or descent) is left where it
    is and noted in ``log``; Showers 2016's clean-up is a side task of the search.
    """
    rig, speed = skill.rig, skill.speed()
    log.attempts[item.id] = log.attempts.get(item.id, 0) + 1
    over = above(skill, item.position, skill.param("approach_mm"))
    if has_gripper(rig):
        yield Grip(rig, False)  # a gripper opens before it goes down
    try:
        yield Move(rig, over, speed=speed, label="approach trash")
        grip = grip_point(skill, item.position, skill.workcell.grasp_offset_mm)
        yield Move(rig, grip, speed=speed, label="descend")
    except ActionFailed as exc:
        log.skipped[item.id] = str(exc)
        yield Move(rig, origin, speed=speed, label="return")
        return
    yield Grip(rig, True)
    yield Pause(skill.clock, skill.param("dwell_s"))
    yield Move(rig, over, speed=speed, label="lift")
    approach = skill.param("approach_mm")
    name, cell = skill.param("bin"), skill.workcell
    if isinstance(name, str) and name in cell.bins and cell.table_z_mm is not None:
        # spread across the bin's inside, clear of what is in it (place does too)
        hang = float(grip[2] - cell.table_z_mm)
        drop = bin_drop(skill, name, bin_xyz, None, hang, skill.param("trash"), item.id)
        point = yield from release_at(skill, drop.tool, approach, skill.param("dwell_s"))
        remember_drop(skill.bb, name, item.id, np.array([*drop.landing, point[2]]))
    else:
        yield from release_steps(skill, bin_xyz, approach, 0.0, skill.param("dwell_s"))
    log.carried += 1
    log.last = (item.id, item.position)
    yield Move(rig, origin, speed=speed, label="return")


class CleanUpParams:
    """The parameters search and clean_up share."""

    PARAMS = (
        Param(
            "trash", "str", "trash", "", "tag role of the markers to clear away", kind="tag_role"
        ),
        Param(
            "bin",
            "any",
            "garbage_bin",
            "mm",
            "place name or [x, y, z] to drop trash over",
            kind="place",
        ),
        Param(
            "bin_radius_mm",
            "float",
            60.0,
            "mm",
            "trash seen this close to the bin is in it",
            minimum=0.0,
            maximum=1000.0,
        ),
        Param(
            "approach_mm",
            "float",
            60.0,
            "mm",
            "height above an object to approach from",
            minimum=0.0,
            maximum=1000.0,
        ),
        Param(
            "dwell_s",
            "float",
            0.3,
            "s",
            "time for the suction to grip or let go",
            minimum=0.0,
            maximum=60.0,
        ),
        Param(
            "max_items",
            "int",
            10,
            "",
            "most trash carries before giving up",
            minimum=0,
            maximum=1000,
        ),
        Param(
            "attempts",
            "int",
            2,
            "",
            "tries per trash marker before leaving it",
            minimum=1,
            maximum=100,
        ),
        *GRIP,
    )


SCAN_PARAMS = (
    Param(
        "sweeps",
        "int",
        2,
        "",
        "legs of the back-and-forth sweep over the survey region",
        minimum=1,
        maximum=100,
    ),
    # one frame per pose: on a sweep each spot is in view from about three poses
    Param("frames", "int", 1, "", "frames to read at each scan pose", minimum=1, maximum=100),
)


def scan_poses(skill: ArmSkill) -> Iterator[np.ndarray]:
    """The tool positions (mm) a sweeping skill looks from, in order.

    Each puts the camera ``workcell.look_height_mm`` over a point of the
    profile's ``workcell.survey`` region (Showers 2016, appendix B turns the base in
    5 degree steps), or as near to that as the arm reaches; computed one at a
    time as the sweep goes.
    """
    cell = skill.workcell
    survey = cell.need("survey", skill.name)
    table_z = cell.need("table_z_mm", skill.name)
    here = needed(skill.rig.arm, "arm").pose()[:3, 3]
    try:
        points = survey_points(survey, float(table_z), here, int(skill.param("sweeps")))
    except ValueError as exc:
        raise SkillFailure(f"{skill.name}: {exc}") from exc
    for point in points:
        yield camera_over(skill, point, cell.look_height_mm)


def scan_look(skill: ArmSkill, want: str | None, tally: Tally | None) -> Look:
    """A look from a scan pose: up to the skill's ``frames``, ending early once ``want``
    is seen; the frames are added to ``tally`` when given."""
    return Look(
        skill.rig,
        skill.clock,
        want=want,
        frames=skill.param("frames"),
        settle=skill.settle(),
        tally=tally,
    )


def clear_here(
    skill: ArmSkill,
    pose: np.ndarray,
    want: str | None,
    log: TrashLog,
    tally: Tally | None = None,
) -> Procedure:
    """Look from ``pose`` and clear trash until none that can be cleared is in view.

    Returns the last sightings. A marker still seen after ``attempts`` tries is
    left where it is; more than ``max_items`` carries fail the skill. The frames
    are added to ``tally`` when given.
    """
    trash = skill.param("trash")
    bin_xyz = skill.point(skill.param("bin"), f"{skill.name}: bin")
    while True:
        sightings = yield scan_look(skill, want, tally)
        log.check(sightings)
        radius = float(skill.param("bin_radius_mm"))
        items = [
            s
            for s in sightings
            if s.role == trash
            and s.id not in log.skipped
            and np.linalg.norm(s.position[:2] - bin_xyz[:2]) > radius
        ]
        if not items:
            return sightings
        item = items[0]
        if log.attempts.get(item.id, 0) >= skill.param("attempts"):
            log.skipped[item.id] = f"still there after {log.attempts[item.id]} tries"
            continue
        if log.carried >= skill.param("max_items"):
            raise SkillFailure(f"{skill.name}: trash still in view after {log.summary()}")
        yield from clean_one(skill, item, pose, bin_xyz, log)
        skill.feedback_message = log.summary()


class ClearsTrash(ArmSkill):
    """A skill that may carry trash to a bin: it shares the run's bin contents
    (:data:`~.bins.BINS_KEY`) with the other skills that let go into bins."""

    def __init__(self, name: str, **params: Any) -> None:
        super().__init__(name, **params)
        share_bins(self.bb)


class CleanUp(ClearsTrash):
    """Pick every trash marker in view and drop it over the garbage bin, then come back.

    Looks from the current pose (or, with ``sweep``, from every scan pose of the
    arc), clears what it sees and looks again until no trash is left in view:
    SUCCESS; FAILURE once ``max_items`` were carried and trash is still there.
    """

    PARAMS = (
        *CleanUpParams.PARAMS,
        Param("sweep", "bool", False, "", "sweep the scan arc instead of looking from here"),
        *SCAN_PARAMS,
        Param("count", "any", None, "", "output: how many were cleared", io="out"),
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm", "tool")
    NEEDS = ("arm", "camera")

    @classmethod
    def workcell_for(cls, params: Mapping[str, Any]) -> tuple[str, ...]:
        """The survey region and table height, only when it sweeps (``sweep`` true or bound)."""
        return ("survey", "table_z_mm") if params.get("sweep") else ()

    def procedure(self) -> Procedure:
        poses = (
            scan_poses(self)
            if self.param("sweep")
            else iter([needed(self.rig.arm, "arm").pose()[:3, 3]])
        )
        log = TrashLog()
        for n, pose in enumerate(poses):
            if self.param("sweep") or n > 0:
                try:
                    yield Move(self.rig, pose, speed=self.speed(), label="scan")
                except ActionFailed:
                    continue
            yield from clear_here(self, pose, None, log)
        self.output("count", log.carried)
        self.feedback_message = log.summary()
        return log.carried


class Search(ClearsTrash):
    """Sweep the camera over the workspace until a tag of role ``tag`` is seen; output its pose.

    Scan poses put the camera over the points of the profile's
    ``workcell.survey`` region (a ring swept in base-angle steps, a rectangle or
    viewpoints), ``sweeps`` legs back and forth. With
    ``clean_up``, trash seen on the way is carried to ``bin`` first. FAILURE when
    the sweeps end without the tag.
    """

    PARAMS = (
        Param("tag", "str", doc="tag role to find", kind="tag_role"),
        Param("pose", "any", None, "mm", "output: the tag's position in the base frame", io="out"),
        Param("clean_up", "bool", False, "", "carry trash seen on the way to `bin`"),
        *SCAN_PARAMS,
        *CleanUpParams.PARAMS,
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm", "tool")
    NEEDS = ("arm", "camera")
    WORKCELL = ("survey", "table_z_mm")

    def procedure(self) -> Procedure:
        tag = self.param("tag")
        refused: list[str] = []
        log = TrashLog()
        tally = Tally()
        count = 0
        for pose in scan_poses(self):
            count += 1
            try:
                yield Move(self.rig, pose, speed=self.speed(), label="scan")
            except ActionFailed as exc:
                refused.append(str(exc))
                continue
            if self.param("clean_up"):
                sightings = yield from clear_here(self, pose, tag, log, tally)
            else:
                sightings = yield scan_look(self, tag, tally)
            found = [s for s in sightings if s.role == tag]
            if found:
                position = found[0].position
                self.output("pose", as_list(position))
                cleaned = f"; {log.summary()}" if self.param("clean_up") else ""
                self.feedback_message = f"found {tag!r} at {fmt(position)}{cleaned}"
                return position
        detail = f"; {len(refused)} refused, first: {refused[0]}" if refused else ""
        family = getattr(self.rig.tracker, "marker_family", None)
        raise SkillFailure(
            f"{self.name}: no {tag!r} tag seen from {count} scan poses "
            f"({tally.describe(family)}){detail}"
        )


__all__ = ["CleanUp", "Search"]
