"""Search the workspace for a tag, and clean up trash markers on the way (seed 004, appendix B).

The report's search turns the base in 5 degree steps, the other joints still,
reversing past 100 degrees either side; at each step it asks the camera for the
wanted tag, and in clean-up mode first carries any trash it sees to the
garbage bin and returns to where it was.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from armtree import Param

from .actions import Look, Move, Sighting, SkillFailure, fmt
from .base import ActionFailed, Procedure, as_list
from .manipulation import ArmSkill, camera_over, pick_steps, release_steps


def sweep_angles(start: float, lo: float, hi: float, step: float, sweeps: int) -> list[float]:
    """Base angles (degrees) of a back-and-forth sweep from ``start`` within [lo, hi].

    First towards ``hi`` then back to ``lo`` and so on, ``sweeps`` legs in all
    (seed 004, appendix B: 5 degree steps, reversing at +/-100 degrees).
    """
    if step <= 0 or hi < lo:
        raise ValueError("a sweep needs step > 0 and range lo <= hi")
    angle = min(max(start, lo), hi)
    out = [angle]
    direction = 1.0
    for _ in range(max(1, sweeps)):
        end = hi if direction > 0 else lo
        while (end - angle) * direction > 1e-9:
            angle = angle + direction * min(step, abs(end - angle))
            out.append(angle)
        direction = -direction
    return out


def clean_steps(
    skill: ArmSkill, sightings: list[Sighting], origin: np.ndarray, trash: str, bin_xyz: np.ndarray
) -> Procedure:
    """Carry every ``trash`` marker in ``sightings`` to the bin, returning to ``origin``; the count."""
    count = 0
    rig = skill.rig
    for s in sightings:
        if s.role != trash:
            continue
        yield from pick_steps(
            skill, s.position, skill.param("approach_mm"), 0.0, skill.param("dwell_s")
        )
        yield from release_steps(
            skill,
            bin_xyz,
            skill.param("approach_mm"),
            skill.param("approach_mm"),
            skill.param("dwell_s"),
        )
        count += 1
        yield Move(rig, origin, speed=skill.speed(), label="return")
    return count


class CleanUpParams:
    """The parameters search and clean_up share."""

    PARAMS = (
        Param("trash", "str", "trash", "", "tag role of the markers to clear away"),
        Param("bin", "any", "garbage_bin", "mm", "place name or [x, y, z] to drop trash over"),
        Param("approach_mm", "float", 60.0, "mm", "height above an object to approach from"),
        Param("dwell_s", "float", 0.3, "s", "time for the suction to grip or let go"),
        Param("max_items", "int", 10, "", "most trash markers to clear before giving up"),
    )


SCAN_PARAMS = (
    Param("radius_mm", "float", 200.0, "mm", "radius of the ring of the table the camera looks at"),
    Param(
        "height_mm", "float", 120.0, "mm", "camera height above the ring (lowered if unreachable)"
    ),
    Param("surface_z_mm", "float", 0.0, "mm", "height of the surface the ring lies on"),
    Param("step_deg", "float", 5.0, "deg", "base-angle step between scan poses"),
    Param("range_deg", "vector", [-100.0, 100.0], "deg", "base-angle range of the sweep"),
    Param("sweeps", "int", 2, "", "legs of the back-and-forth sweep"),
    Param("poses", "list", [], "mm", "explicit scan poses [[x, y, z], ...] instead of the arc"),
    Param("frames", "int", 2, "", "frames to read at each scan pose"),
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


def clear_here(skill: ArmSkill, pose: np.ndarray, want: str | None, cleared: int) -> Procedure:
    """Look from ``pose`` and clear trash until none is in view; (last sightings, cleared so far)."""
    trash = skill.param("trash")
    bin_xyz = skill.point(skill.param("bin"), f"{skill.name}: bin")
    while True:
        sightings = yield Look(
            skill.rig, skill.clock, want=want, frames=skill.param("frames"), settle=skill.settle()
        )
        items = [s for s in sightings if s.role == trash]
        if not items:
            return sightings, cleared
        if cleared >= skill.param("max_items"):
            raise SkillFailure(f"{skill.name}: trash still in view after clearing {cleared}")
        cleared += yield from clean_steps(skill, items[:1], pose, trash, bin_xyz)


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
    PLACE_PARAMS = ("bin",)
    ROLE_PARAMS = ("trash",)

    def procedure(self) -> Procedure:
        poses = scan_poses(self) if self.param("sweep") else iter([self.rig.arm.pose()[:3, 3]])
        cleared = 0
        for n, pose in enumerate(poses):
            if self.param("sweep") or n > 0:
                try:
                    yield Move(self.rig, pose, speed=self.speed(), label="scan")
                except ActionFailed:
                    continue
            _, cleared = yield from clear_here(self, pose, None, cleared)
        self.output("count", cleared)
        return cleared


class Search(ArmSkill):
    """Sweep the camera over the workspace until a tag of role ``tag`` is seen; output its pose.

    Scan poses are on an arc of ``radius_mm`` at ``height_mm``, ``step_deg`` apart
    within ``range_deg`` of the base x-axis, or the explicit ``poses``. With
    ``clean_up``, trash seen on the way is carried to ``bin`` first. FAILURE when
    the sweeps end without the tag.
    """

    PARAMS = (
        Param("tag", "str", doc="tag role to find"),
        Param("pose", "any", None, "mm", "output: the tag's position in the base frame", io="out"),
        Param("clean_up", "bool", False, "", "carry trash seen on the way to `bin`"),
        *SCAN_PARAMS,
        *CleanUpParams.PARAMS,
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm", "tool")
    NEEDS = ("arm", "camera")
    PLACE_PARAMS = ("bin",)
    ROLE_PARAMS = ("tag", "trash")

    def procedure(self) -> Procedure:
        tag = self.param("tag")
        refused: list[str] = []
        cleared = 0
        count = 0
        for pose in scan_poses(self):
            count += 1
            try:
                yield Move(self.rig, pose, speed=self.speed(), label="scan")
            except ActionFailed as exc:
                refused.append(str(exc))
                continue
            if self.param("clean_up"):
                sightings, cleared = yield from clear_here(self, pose, tag, cleared)
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
                self.feedback_message = f"found {tag!r} at {fmt(position)}"
                return position
        detail = f"; {len(refused)} refused, first: {refused[0]}" if refused else ""
        raise SkillFailure(f"{self.name}: no {tag!r} tag seen from {count} scan poses{detail}")


__all__ = ["CleanUp", "Search", "sweep_angles"]
