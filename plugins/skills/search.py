"""Search the workspace for a tag, and clean up trash markers on the way (seed 004, appendix B).

The report's search turns the base in 5 degree steps, the other joints still,
reversing past 100 degrees either side; at each step it asks the camera for the
wanted tag, and in clean-up mode first carries any trash it sees to the
garbage bin and returns to where it was.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from armtree import Param

from .actions import Look, Move, Pause, Sighting, SkillFailure, Suction, fmt
from .base import ActionFailed, Procedure, as_list
from .manipulation import ArmSkill, above, camera_over, grip_point, release_steps


def sweep_angles(start: float, lo: float, hi: float, step: float, sweeps: int) -> list[float]:
    """Base angles (degrees) of a back-and-forth sweep from ``start`` within [lo, hi].

    First towards ``hi`` then back to ``lo`` and so on, ``sweeps`` legs in all
    (seed 004, appendix B: 5 degree steps, reversing at +/-100 degrees). Every
    other leg begins with half a step, so its poses fall between those of the leg
    before: a marker that no pose of one leg shows whole (cut by the image's edge)
    is seen from new poses on the way back, not from the same ones again.
    """
    if step <= 0 or hi < lo:
        raise ValueError("a sweep needs step > 0 and range lo <= hi")
    angle = min(max(start, lo), hi)
    out = [angle]
    direction = 1.0
    for leg in range(max(1, sweeps)):
        end = hi if direction > 0 else lo
        first = 0.5 * step if leg % 2 else step
        while (end - angle) * direction > 1e-9:
            angle = angle + direction * min(first, abs(end - angle))
            first = step
            out.append(angle)
        direction = -direction
    return out


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
    is and noted in ``log``; seed 004's clean-up is a side task of the search.
    """
    rig, speed = skill.rig, skill.speed()
    log.attempts[item.id] = log.attempts.get(item.id, 0) + 1
    over = above(skill, item.position, skill.param("approach_mm"))
    if rig.arm.tool.gripper is not None:
        yield Suction(rig, False)  # a gripper opens before it goes down
    try:
        yield Move(rig, over, speed=speed, label="approach trash")
        grip = grip_point(skill, item.position, skill.param("grasp_offset_mm"))
        yield Move(rig, grip, speed=speed, label="descend")
    except ActionFailed as exc:
        log.skipped[item.id] = str(exc)
        yield Move(rig, origin, speed=speed, label="return")
        return
    yield Suction(rig, True)
    yield Pause(skill.clock, skill.param("dwell_s"))
    yield Move(rig, over, speed=speed, label="lift")
    approach = skill.param("approach_mm")
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
            "grasp_offset_mm",
            "float",
            2.0,
            "mm",
            "tool height above a marker when gripping",
            minimum=-100.0,
            maximum=500.0,
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
        *ArmSkill.LOOK,
        *ArmSkill.GRIP,
    )


SCAN_PARAMS = (
    Param(
        "radius_mm",
        "float",
        200.0,
        "mm",
        "radius of the ring of the table the camera looks at",
        exclusive_minimum=0.0,
        maximum=5000.0,
    ),
    Param(
        "height_mm",
        "float",
        120.0,
        "mm",
        "camera height above the ring (lowered if unreachable)",
        minimum=0.0,
        maximum=5000.0,
    ),
    Param(
        "surface_z_mm",
        "float",
        0.0,
        "mm",
        "height of the surface the ring lies on",
        minimum=-5000.0,
        maximum=5000.0,
    ),
    # A step below 0.1 degree or a range beyond a turn either way would only multiply
    # scan poses (without bound at 1e-9 degrees); such values are refused at load time.
    Param(
        "step_deg",
        "float",
        5.0,
        "deg",
        "base-angle step between scan poses",
        minimum=0.1,
        maximum=360.0,
    ),
    Param(
        "range_deg",
        "vector",
        [-100.0, 100.0],
        "deg",
        "base-angle range of the sweep",
        minimum=-360.0,
        maximum=360.0,
        length=2,
    ),
    Param("sweeps", "int", 2, "", "legs of the back-and-forth sweep", minimum=1, maximum=100),
    Param(
        "poses",
        "list",
        [],
        "mm",
        "explicit scan poses [[x, y, z], ...] instead of the arc",
        max_items=1000,
    ),
    Param("frames", "int", 2, "", "frames to read at each scan pose", minimum=1, maximum=100),
)


def scan_poses(skill: ArmSkill) -> Iterator[np.ndarray]:
    """The tool positions (mm) a sweeping skill looks from, in order (see :data:`SCAN_PARAMS`).

    On the arc, each puts the camera ``height_mm`` over a point of the ring
    (seed 004, appendix B turns the base in 5 degree steps), or as near to that
    as the arm reaches; computed one at a time as the sweep goes.
    """
    explicit = skill.param("poses")
    if explicit:
        yield from (skill.point(p, f"{skill.name}: poses") for p in explicit)
        return
    lo, hi = (float(v) for v in skill.param("range_deg"))
    here = skill.rig.arm.pose()[:3, 3]
    start = math.degrees(math.atan2(here[1], here[0]))
    try:
        angles = sweep_angles(
            start, lo, hi, float(skill.param("step_deg")), int(skill.param("sweeps"))
        )
    except ValueError as exc:
        raise SkillFailure(f"{skill.name}: {exc}") from exc
    r, h = float(skill.param("radius_mm")), float(skill.param("height_mm"))
    z = float(skill.param("surface_z_mm"))
    for a in angles:
        ring = np.array([r * math.cos(math.radians(a)), r * math.sin(math.radians(a)), z])
        yield camera_over(skill, ring, h)


def clear_here(skill: ArmSkill, pose: np.ndarray, want: str | None, log: TrashLog) -> Procedure:
    """Look from ``pose`` and clear trash until none that can be cleared is in view.

    Returns the last sightings. A marker still seen after ``attempts`` tries is
    left where it is; more than ``max_items`` carries fail the skill.
    """
    trash = skill.param("trash")
    bin_xyz = skill.point(skill.param("bin"), f"{skill.name}: bin")
    while True:
        sightings = yield Look(
            skill.rig, skill.clock, want=want, frames=skill.param("frames"), settle=skill.settle()
        )
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


class CleanUp(ArmSkill):
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

    def procedure(self) -> Procedure:
        poses = scan_poses(self) if self.param("sweep") else iter([self.rig.arm.pose()[:3, 3]])
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


class Search(ArmSkill):
    """Sweep the camera over the workspace until a tag of role ``tag`` is seen; output its pose.

    Scan poses are on an arc of ``radius_mm`` at ``height_mm``, ``step_deg`` apart
    within ``range_deg`` of the base x-axis, or the explicit ``poses``. With
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

    def procedure(self) -> Procedure:
        tag = self.param("tag")
        refused: list[str] = []
        log = TrashLog()
        count = 0
        for pose in scan_poses(self):
            count += 1
            try:
                yield Move(self.rig, pose, speed=self.speed(), label="scan")
            except ActionFailed as exc:
                refused.append(str(exc))
                continue
            if self.param("clean_up"):
                sightings = yield from clear_here(self, pose, tag, log)
            else:
                sightings = yield Look(
                    self.rig,
                    self.clock,
                    want=tag,
                    frames=self.param("frames"),
                    settle=self.settle(),
                )
            found = [s for s in sightings if s.role == tag]
            if found:
                position = found[0].position
                self.output("pose", as_list(position))
                cleaned = f"; {log.summary()}" if self.param("clean_up") else ""
                self.feedback_message = f"found {tag!r} at {fmt(position)}{cleaned}"
                return position
        detail = f"; {len(refused)} refused, first: {refused[0]}" if refused else ""
        raise SkillFailure(f"{self.name}: no {tag!r} tag seen from {count} scan poses{detail}")


__all__ = ["CleanUp", "Search", "sweep_angles"]
