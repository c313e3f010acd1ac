"""Pick and place that see what they act on, and check with the camera that it worked.

Seed 004 ("Loading a ducky"): the pump holds an object while the tool touches
it; the arm moves and releases it. The report's static ducky position needed
frequent touch tests; here a place is only where to look: :func:`~.locate.locate`
finds the tag around it, and a pick or place that the camera contradicts is a
FAILURE with the measured numbers, which a retry in the tree can act on.

Post-conditions, with the sensors the rig has:

* after a pick, eye-in-hand: the camera looks back at the spot, and a marker still
  lying there failed the grip; eye-to-hand: the marker must have risen with the
  tool (seed 000's set-up sees tool and object in one view), or, hidden under the
  gripper, be gone from the spot once the arm has carried it out of the view;
* after a place: the held object's marker must be on the target within
  ``place_tolerance_mm`` (on a marker) or near the place (a bin may hide it).

A check the rig cannot make (the marker hidden under the gripper, no tag to look
for) is said in the feedback and written to the run log as an ``unverified``
event, never claimed. Positions are the tool centre or marker centres in the
base frame, mm.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from typing import Any

import numpy as np

from armtree import Param
from armtree.api.skill.actions import ArmHome, Grip, Look, Move, Pause, SkillFailure, fmt
from armtree.api.skill.arm import UP, ArmSkill, above
from armtree.api.skill.base import ActionFailed, Procedure, as_list
from armtree.api.skill.eye import eye_of
from armtree.api.skill.reach import nearest_reachable, reachable
from armtree.api.skill.sightline import out_of_view
from armtree.config.params import Binding
from armtree.maths.perception.frames import EYE_IN_HAND

from .bins import Drop, contents_of, inside, plan_drop
from .footprint import clear_grip, neighbours
from .grip import GRIP, grip_point, has_gripper
from .locate import locate, look_over, nearest

#: A marker this much higher than the spot it was gripped at has risen with the tool (mm).
RISEN_MM = 10.0
#: An object put on a target marker rests at least this much above it (mm).
ON_TOP_MM = 5.0
#: Steps of the look around a place the check did not see the object at, as a fraction
#: of the camera's view on the table.
CHECK_STEP = 0.3
#: A held marker this far (mm) beside or below where the arm's joints put it moves the
#: release; one farther than the limit is not the held object's.
HELD_TOLERANCE_MM = 4.0
HELD_LIMIT_MM = 40.0
#: How far a release point may move to within reach (mm), and how much lower at most.
RELEASE_SLACK_MM = 15.0
RELEASE_DROP_MM = 3.0
#: A gripper's jaws still hold an object gripped this fraction of its marker's side off centre.
GRIP_HOLD = 0.2


def pick_steps(
    skill: ArmSkill,
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
    rig, speed = skill.rig, skill.speed()
    # a suction cup holds anywhere on the marker's face: up to 3 mm inside its edge
    edge = edge_toward_base(target, marker_size, marker_yaw)
    inward = 0.0 if has_gripper(rig) else max(0.0, edge - 3.0)
    grip = grip_point(skill, target, grasp_offset, inward)
    # jaws closing on it hold an object gripped up to a fifth of its marker off centre
    hold = GRIP_HOLD * marker_size if has_gripper(rig) else max(0.0, 0.5 * marker_size - 3.0)
    grip = clear_of_neighbours(skill, target, grip, grasp_offset, approach, marker, hold)
    over = above(skill, grip - UP * grasp_offset, approach + grasp_offset)
    if has_gripper(rig):
        yield Grip(rig, False)  # a gripper opens before it goes down
    yield Move(rig, over, speed=speed, label="approach")
    yield Move(rig, grip, speed=speed, label="descend")
    yield Grip(rig, True)
    yield Pause(skill.clock, dwell)
    yield Move(rig, over, speed=speed, label="lift")
    return grip


def clear_of_neighbours(
    skill: ArmSkill,
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
    model = skill.rig.arm.model
    objects = neighbours(skill, target, marker)
    if not objects:
        return grip
    over = above(skill, grip - UP * grasp_offset, approach + grasp_offset)
    try:
        near = model.ik(over, near=skill.rig.arm.joints())
    except ValueError:  # the approach point is out of reach: the move will say so
        return grip
    found = clear_grip(model, grip, near, objects, hold)
    if not found.blocked_by:
        return grip
    what = ", ".join(
        f"the {o.role} (marker {o.id}) at {fmt(o.centre[:2])}" for o in found.blocked_by
    )
    if found.grip is None:
        skill.note("footprint", refused=as_list(grip), hits=[o.id for o in found.blocked_by])
        raise SkillFailure(
            f"{skill.name}: gripping at {fmt(grip)} would hit {what} "
            f"(the tool's boxes at the grip height), and no grip within {hold:.1f} mm "
            "beside it clears it"
        )
    skill.note(
        "footprint",
        moved=as_list(found.grip),
        shift_mm=round(found.shift_mm, 1),
        hits=[o.id for o in found.blocked_by],
    )
    return found.grip


def edge_toward_base(target: np.ndarray, size: float, yaw: float | None) -> float:
    """Distance (mm) from a ``size`` mm marker's centre at ``target`` to its edge in the
    direction of the arm's base: half its size across its sides, more across a corner;
    half its size when its heading ``yaw`` (radians) is unknown."""
    half = 0.5 * size
    if yaw is None or np.hypot(target[0], target[1]) < 1e-6:
        return half
    angle = np.arctan2(-target[1], -target[0]) - yaw
    return float(half / max(abs(np.cos(angle)), abs(np.sin(angle))))


def release_steps(
    skill: ArmSkill,
    target: np.ndarray,
    approach: float,
    release: float,
    dwell: float,
    check: Callable[[np.ndarray], Procedure] | None = None,
) -> Procedure:
    """Approach above ``target``, descend to ``release`` mm above it, open the tool, lift back
    (``check``: as :func:`release_at`'s).

    A release point just out of reach (a Duckybot parked at the edge of a small
    workspace) gives way to the nearest reachable one within
    :data:`RELEASE_SLACK_MM`, no lower than :data:`RELEASE_DROP_MM` under it.
    """
    point = target + UP * release
    model = skill.rig.arm.model
    if not reachable(model, point):
        near = nearest_reachable(
            model, point, span=2 * RELEASE_SLACK_MM, min_z=point[2] - RELEASE_DROP_MM
        )
        if near is not None and np.linalg.norm(near - point) <= RELEASE_SLACK_MM:
            point = near
    return (yield from release_at(skill, point, max(0.0, approach - release), dwell, check))


def release_at(
    skill: ArmSkill,
    point: np.ndarray,
    approach: float,
    dwell: float,
    check: Callable[[np.ndarray], Procedure] | None = None,
) -> Procedure:
    """Approach ``approach`` mm above ``point`` (as much as reachable), descend to it, open
    the tool, lift back. Returns the point let go at: ``check(point)``, when given, runs
    at the approach and returns the point to descend to instead (a correction)."""
    rig, speed = skill.rig, skill.speed()
    over = above(skill, point, approach)
    yield Move(rig, over, speed=speed, label="approach")
    if check is not None:
        point = yield from check(point)
        over = np.array([point[0], point[1], max(over[2], point[2])])
    if over[2] > point[2] + 1e-6:
        yield Move(rig, point, speed=speed, label="descend")
    yield Grip(rig, False)
    yield Pause(skill.clock, dwell)
    if over[2] > point[2] + 1e-6:
        yield Move(rig, over, speed=speed, label="lift")
    return point


def tool_pose_at(rig: Any, xyz: np.ndarray) -> np.ndarray:
    """The tool's pose (4x4) with its centre at ``xyz``, as the arm's model reaches it."""
    model = rig.arm.model
    return model.fk(model.ik(np.asarray(xyz, dtype=float), near=rig.arm.joints()))


def tool_engaged(rig: Any) -> bool:
    """True when the rig's tool reports gripping (``rig.tool.holding``: suction on, a gripper
    nearer closed than open); False for a rig without one."""
    tool = getattr(rig, "tool", None)
    return tool is not None and bool(tool.holding)


def move_out_of_view(skill: ArmSkill, point: np.ndarray) -> Procedure:
    """Eye-to-hand: take the arm to where it hides ``point`` least (a refused move stays put)."""
    clear = out_of_view(skill, point)
    if clear is None:
        return
    with contextlib.suppress(ActionFailed):
        yield Move(skill.rig, clear, speed=skill.speed(), label="out of view")


def verify_pick(
    skill: ArmSkill,
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
    rig = skill.rig
    in_hand = rig.camera.mount == EYE_IN_HAND
    if in_hand:
        after = yield from look_over(skill, spot, skill.workcell.look_height_mm, None, 2)
    else:
        after = yield Look(rig, skill.clock, frames=2, settle=skill.settle())
    if marker is None:
        mine = nearest(after, tag, spot, 4.0 * tolerance)
    else:
        mine = next((s for s in after if s.id == marker), None)
    if mine is not None:
        off = mine.position - spot
        flat, rise = float(np.linalg.norm(off[:2])), float(off[2])
        if flat < tolerance and abs(rise) < tolerance:
            skill.note("check", check="pick", ok=False, tag=tag, offset_mm=as_list(off))
            raise SkillFailure(
                f"{skill.name}: the {tag!r} tag is still at {fmt(mine.position)}, "
                f"{flat:.1f} mm from where it was gripped: the grip failed"
            )
        if not in_hand:
            tool = rig.arm.pose()[:3, 3]
            to_tool = float(np.linalg.norm(mine.position[:2] - tool[:2]))
            if rise < RISEN_MM or to_tool > 2.0 * tolerance:
                skill.note("check", check="pick", ok=False, tag=tag, offset_mm=as_list(off))
                raise SkillFailure(
                    f"{skill.name}: the {tag!r} tag is at {fmt(mine.position)}, {rise:.1f} mm "
                    f"above the spot and {to_tool:.1f} mm beside the tool: it did not come with it"
                )
            skill.note("check", check="pick", ok=True, tag=tag, rise_mm=round(rise, 1))
            return f"the tag rose {rise:.0f} mm with the tool"
    if not in_hand and not looked_away:
        # hidden under the tool, or the arm hides the spot: carry it out of the view, look again
        yield from move_out_of_view(skill, spot)
        return (yield from verify_pick(skill, tag, marker, spot, tolerance, looked_away=True))
    skill.note("check", check="pick", ok=True, tag=tag, how="spot looked at, tag gone")
    return "the spot is empty"


def verify_place(
    skill: ArmSkill,
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
    rig = skill.rig
    cell = skill.workcell
    in_hand = rig.camera.mount == EYE_IN_HAND
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
            after = yield from look_over(skill, point, cell.look_height_mm, obj, 2)
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
        yield from move_out_of_view(skill, target)
        after = yield Look(rig, skill.clock, want=obj, frames=2, settle=skill.settle())
        seen = nearest([s for s in after if marker is None or s.id == marker], obj, target)
    if seen is None:
        if in_hand and on_marker:
            skill.note("check", check="place", ok=False, tag=obj, seen=False)
            raise SkillFailure(
                f"{skill.name}: no {obj!r} tag in view over {fmt(target)} or around it "
                "after letting go"
            )
        return skill.unverified(f"the {obj!r} tag is not in view after letting go")
    off = seen.position - target
    flat = float(np.linalg.norm(off[:2]))
    ok = flat <= limit and (not on_marker or off[2] >= ON_TOP_MM)
    skill.note("check", check="place", ok=ok, tag=obj, offset_mm=as_list(off), limit_mm=limit)
    if not ok:
        where = "on" if on_marker else "at"
        raise SkillFailure(
            f"{skill.name}: the {obj!r} tag is at {fmt(seen.position)}, {flat:.1f} mm from "
            f"{fmt(target)} and {off[2]:+.1f} mm above it: not {where} the target "
            f"(tolerance {limit:g} mm)"
        )
    return f"the {obj!r} tag is {flat:.0f} mm from the target"


def bin_drop(
    skill: ArmSkill,
    name: str,
    place: np.ndarray,
    held: np.ndarray | None,
    hang: float,
    role: str,
    marker: int | None,
) -> Drop:
    """Where to let go in the bin at place ``name``: :func:`~.bins.plan_drop` over what
    this run let go there and the markers last seen inside it (not the held ``marker``).

    ``held``: the held marker in the tool frame (None: at the tool centre); ``hang``: how
    far the held object reaches below the tool (mm); ``role``: its tag role. Raises
    :class:`SkillFailure`, still holding, when no reachable release clears what is there.
    """
    rig = skill.rig
    spec = skill.workcell.bins[name]
    contents = contents_of(rig).of(name)
    view = eye_of(rig).last
    if view is not None:
        contents += [
            s.position for s in view.sightings if s.id != marker and inside(spec, place, s.position)
        ]
    tag = rig.tags.get(role) if role else None
    offset = None
    if held is not None:
        with contextlib.suppress(ValueError):  # the place's IK (Unreachable)
            offset = (tool_pose_at(rig, place) @ held)[:2] - place[:2]
    drop = plan_drop(
        rig.arm.model, place, spec, contents, hang, tag.size_mm if tag is not None else 0.0, offset
    )
    if drop is None:
        raise SkillFailure(
            f"{skill.name}: no room left in {name!r} within reach: the held object would "
            f"not clear its rim or the {len(contents)} thing(s) in it; still holding it"
        )
    skill.note(
        "bin_drop",
        bin=name,
        landing_mm=as_list(drop.landing),
        tool_mm=as_list(drop.tool),
        room_mm=None if np.isinf(drop.room_mm) else round(drop.room_mm, 1),
        contents=len(contents),
    )
    return drop


def skipped(value: Any) -> list[int]:
    """Marker ids from a ``skip`` parameter's value (None or a list)."""
    return [int(v) for v in value] if isinstance(value, (list, tuple)) else []


class Gripping(ArmSkill):
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

    def grip(self, target: np.ndarray, tag: str | None, marker: int | None) -> Procedure:
        """Grip at ``target`` and check the grip; a failure lets go on purpose and skips the marker."""
        try:
            spec = self.rig.tags.get(tag) if tag else None
            grip = yield from pick_steps(
                self,
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
                self.feedback_message = yield from verify_pick(
                    self, tag, marker, target, float(self.param("verify_tolerance_mm"))
                )
            # where the marker sits on the tool: the place check looks where it will land
            eye = eye_of(self.rig)
            if marker is not None:
                eye.forget(marker)  # no longer where it stood
            with contextlib.suppress(ValueError):  # the grip point's IK (Unreachable)
                eye.held = np.linalg.inv(tool_pose_at(self.rig, grip)) @ np.append(target, 1.0)
            table = self.workcell.table_z_mm
            eye.held_hang_mm = None if table is None else float(grip[2] - table)
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


class PuttingDown(ArmSkill):
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

    def put_down(self, target: np.ndarray, on_marker: bool) -> Procedure:
        """Let go over ``target`` (``workcell.release_offset_mm`` above a marker, at a place
        itself, across the inside of a bin the profile's ``workcell.bins`` describes) and
        check where the object went."""
        release = self.workcell.release_offset_mm if on_marker else 0.0
        eye = eye_of(self.rig)
        held, eye.held = eye.held, None
        hang, eye.held_hang_mm = eye.held_hang_mm, None
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
            contents_of(self.rig).record(
                bin_name, self.bin_key(marker), np.array([*landing[:2], point[2]])
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
            self.feedback_message = yield from verify_place(
                self,
                obj,
                target,
                on_marker,
                float(self.param("place_tolerance_mm")),
                None if marker is None else int(marker),
                expected,
            )
            if bin_name is not None and marker is not None and eye.last is not None:
                seen = next((s for s in eye.last.sightings if s.id == int(marker)), None)
                if seen is not None:
                    contents_of(self.rig).record(bin_name, int(marker), seen.position)
        return released

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
        expected = (rig.arm.pose() @ held)[:3]
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
        if not reachable(rig.arm.model, corrected):
            raise SkillFailure(
                f"{self.name}: the held {obj!r} tag is at {fmt(seen.position)}, {flat:.1f} mm "
                f"beside and {low:.1f} mm below where the arm's joints put it, and the "
                f"corrected release {fmt(corrected)} is out of reach; still holding it"
            )
        self.note("corrected", why="held marker off the tool", point_mm=as_list(corrected))
        return corrected

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
        """Where to let go in the bin at place ``name`` (:func:`bin_drop`)."""
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


__all__ = [
    "Grasp",
    "bin_drop",
    "Gripping",
    "Pick",
    "Place",
    "PuttingDown",
    "Release",
    "pick_steps",
    "release_at",
    "release_steps",
    "verify_pick",
    "verify_place",
]
