"""Pick and place with a suction cup, and the steps that locate a marker before them.

Seed 004 ("Loading a ducky"): the pump holds an object while the tool touches
it; the arm moves and releases it. Positions are the tool centre in the base
frame, mm; a place's z is the height where the tool touches the object.
"""

from __future__ import annotations

import numpy as np

from armtree import Param
from armtree.perception import EYE_IN_HAND, tool_for_camera_over

from .actions import Look, Move, Pause, Sighting, SkillFailure, Suction, fmt
from .base import Procedure, Skill, as_list
from .reach import highest_reachable, lowest_reachable, nearest_reachable, reachable

UP = np.array([0.0, 0.0, 1.0])


def camera_over(
    skill: ArmSkill, point: np.ndarray, height: float, min_height: float = 40.0
) -> np.ndarray:
    """Tool position (mm) putting the camera ``height`` mm over ``point``, or as near as reachable.

    Eye-in-hand: lower heights down to ``min_height`` are tried in 5 mm steps,
    then the reachable tool position nearest the wanted one; the tool never
    goes below the profile's ``workcell.clearance_z_mm``. Eye-to-hand: the tool simply goes
    ``height`` above the point (out of the way is the caller's business).
    Raises :class:`SkillFailure` when nothing near is reachable.
    """
    rig = skill.rig
    model = rig.arm.model
    if rig.camera.mount != EYE_IN_HAND:
        return point + UP * height
    min_z = skill.clearance()
    q_near = rig.arm.joints()

    home_z = float(model.position(model.home)[2])

    def rotation_at(xyz: np.ndarray) -> np.ndarray:
        # the orientation, not the point, matters here: for positioning arms it follows
        # the direction from the base, so a reachable point at home height will do
        for cand in (xyz, np.array([xyz[0], xyz[1], home_z])):
            if reachable(model, cand):
                return model.fk(model.ik(cand, near=q_near))[:3, :3]
        reach = nearest_reachable(model, xyz)
        if reach is None:
            return np.eye(3)
        return model.fk(model.ik(reach, near=q_near))[:3, :3]

    def over(h: float) -> np.ndarray:
        return tool_for_camera_over(model, point, h, rig.camera.extrinsics, rotation_at=rotation_at)

    tool = point + UP * height
    for h in np.arange(height, min(min_height, height) - 1e-9, -5.0):
        tool = over(h)
        if min_z is not None and tool[2] < min_z:
            # raise the camera until the tool clears, and stop lowering
            tool = over(h + min_z - tool[2])
            if reachable(model, tool):
                return tool
            break
        if reachable(model, tool):
            return tool
    near = nearest_reachable(model, tool, min_z=min_z)
    if near is None:
        raise SkillFailure(f"cannot bring the camera over {fmt(point)}: nothing near is reachable")
    return near


def above(skill: Skill, target: np.ndarray, height: float) -> np.ndarray:
    """``target`` raised by ``height`` mm, or by as much of it as the arm can reach."""
    want = target + UP * height
    model = skill.rig.arm.model
    if height <= 0 or reachable(model, want):
        return want
    best = highest_reachable(model, target, target[2], target[2] + height)
    return want if best is None else best


def look_over(
    skill: Skill, point: np.ndarray | None, height: float, want: str | None, frames: int = 3
) -> Procedure:
    """Bring the camera ``height`` mm above ``point`` (stay put if None) and look.

    Returns the list of :class:`Sighting`.
    """
    rig = skill.rig
    if point is not None and rig.camera.mount == EYE_IN_HAND:
        tool = camera_over(skill, point, height)
        yield Move(rig, tool, speed=skill.speed(), label="look over")
    return (yield Look(rig, skill.clock, want=want, frames=frames, settle=skill.settle()))


def nearest(
    sightings: list[Sighting], role: str, near: np.ndarray | None, radius: float | None = None
) -> Sighting | None:
    """The sighting of ``role`` nearest to ``near`` (mm, in the xy plane), within ``radius`` if given."""
    cands = [s for s in sightings if s.role == role]
    if not cands:
        return None
    if near is None:
        return cands[0]
    dist = [float(np.linalg.norm(s.position[:2] - near[:2])) for s in cands]
    best = int(np.argmin(dist))
    if radius is not None and dist[best] > radius:
        return None
    return cands[best]


def grip_point(skill: ArmSkill, target: np.ndarray, grasp_offset: float) -> np.ndarray:
    """Where the tool touches ``target``: ``grasp_offset`` above it, or up to ``reach_slack_mm``
    higher when that is out of reach (a suction cup grips within a few millimetres)."""
    want = target + UP * grasp_offset
    model = skill.rig.arm.model
    if reachable(model, want):
        return want
    slack = float(skill.param("reach_slack_mm"))
    best = lowest_reachable(model, want, want[2], want[2] + slack)
    return want if best is None else best


def pick_steps(
    skill: ArmSkill, target: np.ndarray, approach: float, grasp_offset: float, dwell: float
) -> Procedure:
    """Approach above ``target``, descend, suction on, let it grip, lift back."""
    rig, speed = skill.rig, skill.speed()
    over = above(skill, target, approach)
    if rig.arm.tool.gripper is not None:
        yield Suction(rig, False)  # a gripper opens before it goes down
    yield Move(rig, over, speed=speed, label="approach")
    yield Move(rig, grip_point(skill, target, grasp_offset), speed=speed, label="descend")
    yield Suction(rig, True)
    yield Pause(skill.clock, dwell)
    yield Move(rig, over, speed=speed, label="lift")


def release_steps(
    skill: Skill, target: np.ndarray, approach: float, release: float, dwell: float
) -> Procedure:
    """Approach above ``target``, descend to ``release`` mm above it, suction off, lift back."""
    rig, speed = skill.rig, skill.speed()
    over = above(skill, target + UP * release, max(0.0, approach - release))
    yield Move(rig, over, speed=speed, label="approach")
    if over[2] > target[2] + release + 1e-6:
        yield Move(rig, target + UP * release, speed=speed, label="descend")
    yield Suction(rig, False)
    yield Pause(skill.clock, dwell)
    if over[2] > target[2] + release + 1e-6:
        yield Move(rig, over, speed=speed, label="lift")


class ArmSkill(Skill):
    """A skill with the common motion parameters ``speed`` and ``settle_s``."""

    COMMON = (
        Param(
            "speed",
            "float",
            1.0,
            "",
            "fraction of the arm's maximum speed, 0 to 1",
            exclusive_minimum=0.0,
            maximum=1.0,
        ),
        Param(
            "settle_s",
            "float",
            0.15,
            "s",
            "wait after a move before a frame counts",
            minimum=0.0,
            maximum=60.0,
        ),
    )
    #: Parameters of skills that grip with the suction cup.
    GRIP = (
        Param(
            "reach_slack_mm",
            "float",
            4.0,
            "mm",
            "grip this much higher at most when the touching point is out of reach",
            minimum=0.0,
            maximum=100.0,
        ),
    )

    def speed(self) -> float:
        """The ``speed`` parameter, clipped to (0, 1]."""
        return float(min(1.0, max(0.01, self.param("speed"))))

    def settle(self) -> float:
        """The ``settle_s`` parameter."""
        return float(self.param("settle_s"))

    def clearance(self) -> float | None:
        """The lowest tool height while looking around (mm, the profile's
        ``workcell.clearance_z_mm``); None when the profile sets no limit."""
        return self.workcell.clearance_z_mm


class Pick(ArmSkill):
    """Pick an object with the suction cup: locate its tag, approach, descend, grip, lift.

    With ``tag`` and a camera, the marker nearest to ``from`` (or seen from the
    current pose) gives the position; otherwise ``from`` (a place, a pose or a
    ``{key}``) does. After the lift, the camera looks back at the spot: a marker
    still lying there is a failed grip (FAILURE).
    """

    PARAMS = (
        Param(
            "tag", "str", "", "", "tag role of the object (empty: use `from` only)", kind="tag_role"
        ),
        Param(
            "from",
            "any",
            None,
            "mm",
            "place name, [x, y, z] or {key}: where the object is",
            kind="place",
        ),
        Param(
            "approach_mm",
            "float",
            60.0,
            "mm",
            "height above the object to approach from and lift to",
            minimum=0.0,
            maximum=1000.0,
        ),
        Param(
            "dwell_s", "float", 0.3, "s", "time for the suction to grip", minimum=0.0, maximum=60.0
        ),
        Param("verify", "bool", True, "", "check with the camera that the object left its spot"),
        Param(
            "verify_tolerance_mm",
            "float",
            10.0,
            "mm",
            "a marker this close to the pick spot was not picked",
            exclusive_minimum=0.0,
            maximum=1000.0,
        ),
        Param("pose", "any", None, "mm", "output: where the object was picked", io="out"),
        *ArmSkill.GRIP,
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm", "tool")

    def procedure(self) -> Procedure:
        tag = self.param("tag")
        source = self.param("from")
        target = None if source is None else self.point(source, f"{self.name}: from")
        seen = None
        if tag and self.rig.camera is not None and self.rig.tracker is not None:
            cell = self.workcell
            sightings = yield from look_over(self, target, cell.look_height_mm, tag)
            seen = nearest(
                sightings, tag, target, cell.search_radius_mm if target is not None else None
            )
            if seen is not None:
                target = seen.position
            elif target is None:
                raise SkillFailure(f"{self.name}: no {tag!r} tag in view")
        if target is None:
            raise SkillFailure(f"{self.name}: give `from` (a place or pose) or a `tag` to see")
        yield from pick_steps(
            self,
            target,
            self.param("approach_mm"),
            self.workcell.grasp_offset_mm,
            self.param("dwell_s"),
        )
        tool = self.rig.arm.tool
        if tool.gripper is None and not tool.suction:
            raise SkillFailure(f"{self.name}: the suction pump is off after gripping")
        if seen is not None and self.param("verify"):
            # look back at the spot: a marker still lying there was not picked
            after = yield from look_over(self, target, self.workcell.look_height_mm, None, 2)
            left = nearest(after, tag, target, self.param("verify_tolerance_mm"))
            if left is not None and abs(left.position[2] - target[2]) < self.param(
                "verify_tolerance_mm"
            ):
                raise SkillFailure(
                    f"{self.name}: the {tag!r} tag is still at {fmt(target)}; the grip failed"
                )
        self.output("pose", as_list(target))
        return target


class Place(ArmSkill):
    """Put the held object down: approach, descend to the release height, suction off, lift.

    ``at`` is a place, a pose or a ``{key}``; with ``tag`` and a camera the
    marker of that role nearest to ``at`` is looked up again first, so a target
    that moved a little is still hit; when it is not in view, ``at`` stands
    (or, with ``require_tag``, the skill fails and nothing is released). On a
    marker (``tag``) the tool lets go ``workcell.release_offset_mm`` above it;
    without one, ``at`` is the release point itself.
    """

    PARAMS = (
        Param(
            "at",
            "any",
            doc="place name, [x, y, z] or {key}: where to put the object",
            unit="mm",
            kind="place",
        ),
        Param(
            "tag",
            "str",
            "",
            "",
            "tag role marking the target, looked up again before placing",
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
        Param("require_tag", "bool", False, "", "fail when `tag` is not seen (else place at `at`)"),
        Param(
            "dwell_s",
            "float",
            0.3,
            "s",
            "time for the suction to let go",
            minimum=0.0,
            maximum=60.0,
        ),
        Param("pose", "any", None, "mm", "output: where the object was released", io="out"),
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm", "tool")

    def procedure(self) -> Procedure:
        target = self.point(self.param("at"), f"{self.name}: at")
        tag = self.param("tag")
        cell = self.workcell
        # on a marker the tool lets go the held object's height above it; a place is
        # the release point itself
        release = cell.release_offset_mm if tag else 0.0
        if tag and self.rig.camera is not None and self.rig.tracker is not None:
            sightings = yield from look_over(self, target, cell.look_height_mm, tag)
            seen = nearest(sightings, tag, target, cell.search_radius_mm)
            if seen is not None:
                target = seen.position
            elif self.param("require_tag"):
                raise SkillFailure(
                    f"{self.name}: no {tag!r} tag within {cell.search_radius_mm:g} mm of {fmt(target)}"
                )
        yield from release_steps(
            self, target, self.param("approach_mm"), release, self.param("dwell_s")
        )
        released = target + UP * release
        self.output("pose", as_list(released))
        return released
