"""The simulated world as ``expect:`` predicates read it (:class:`armtree.api.outcomes.truth.WorldTruth`).

:func:`world_truth` reports a running world's ground truth at the end of a run;
:func:`scene_truth` the nominal world a profile describes, for checking names
while a tree loads. A body's tag role is that of its marker in the profile's
``tags:`` (else its kind's: a bare ducky is still a ducky).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable

from armtree.api.outcomes.truth import DUCKYBOTS, MARKERS, TOOL, WorldObject, WorldTruth
from armtree.api.views import ProfileView
from armtree.config.profile_access import profile_section
from armtree.loader.profile import Profile

from .scene import KINDS
from .scene_spec import MarkerSpec, SceneSpec
from .world import World


def _tag_roles(profile: ProfileView) -> list[str]:
    """The tag roles of the profile's ``tags:``."""
    return [str(role) for role in (profile_section(profile, "tags", {}) or {})]


def _role(kind: str, marker: MarkerSpec | None) -> str | None:
    if marker is not None and marker.role is not None:
        return marker.role
    return KINDS.get(kind, {}).get("role")


def _places(profile: ProfileView) -> dict[str, tuple[float, float, float]]:
    places = profile_section(profile, "places", {}) or {}
    return {str(k): (float(v[0]), float(v[1]), float(v[2])) for k, v in places.items()}


def _roles_of(objects: Iterable[WorldObject], tags: list[str]) -> dict[str, list[str]]:
    roles: dict[str, list[str]] = {role: [] for role in tags}
    for obj in objects:
        if obj.role is not None:
            roles.setdefault(obj.role, []).append(obj.name)
    return roles


def scene_truth(scene: SceneSpec, profile: Profile) -> WorldTruth:
    """The world as the profile places it (Duckybots at their start), for load-time checks."""
    tags = _tag_roles(profile)
    bodies = [*scene.objects, *(bot.body for bot in scene.duckybots)]
    objects = {
        b.name: WorldObject(
            name=b.name,
            kind=b.kind,
            role=_role(b.kind, b.marker),
            position=(float(b.position[0]), float(b.position[1]), float(b.position[2])),
            size=(float(b.size[0]), float(b.size[1]), float(b.size[2])),
            yaw_deg=math.degrees(b.yaw),
            container=b.kind == "bin",
        )
        for b in bodies
    }
    return WorldTruth(
        objects=objects, roles=_roles_of(objects.values(), tags), places=_places(profile)
    )


def world_truth(world: World, profile: ProfileView) -> WorldTruth:
    """The world's ground truth now: every body, what holds it, collisions, slips and drops;
    in ``extra`` the Duckybots' phases and poses, the tool centre and the marker centres
    (for the built-in ``parked`` and ``tool_within_mm``)."""
    tags = _tag_roles(profile)
    with world.lock:
        objects = {}
        for name, b in sorted(world.bodies.items()):
            p = b.pose[:3, 3]
            objects[name] = WorldObject(
                name=name,
                kind=b.kind,
                role=_role(b.kind, b.marker),
                position=(round(float(p[0]), 3), round(float(p[1]), 3), round(float(p[2]), 3)),
                size=(float(b.size[0]), float(b.size[1]), float(b.size[2])),
                yaw_deg=round(math.degrees(b.yaw), 3),
                on=None if b.held or b.falling else b.support,
                inside=world.in_bin(b),
                held=b.held,
                container=b.kind == "bin",
            )
        events = list(world.events)
        extra = {
            DUCKYBOTS: {
                name: {
                    "phase": bot.phase,
                    "pose": (bot.state.x, bot.state.y, math.degrees(bot.state.theta)),
                }
                for name, bot in world.duckybots.items()
            },
            MARKERS: {
                name: tuple(float(v) for v in b.top_pose()[:3, 3])
                for name, b in world.bodies.items()
                if b.marker is not None
            },
        }
        if world.arm is not None:
            extra[TOOL] = tuple(float(v) for v in world.arm.tool_pose[:3, 3])
        return WorldTruth(
            objects=objects,
            roles=_roles_of(objects.values(), tags),
            places=_places(profile),
            held=world.held,
            collisions=[dataclasses.asdict(c) for c in world.collisions.log],
            missed_steps=[
                e.detail | {"time": round(e.time, 6)} for e in events if e.kind == "missed_steps"
            ],
            drops=[e.detail | {"time": round(e.time, 6)} for e in events if e.kind == "drop"],
            extra=extra,
        )
