"""The scene a profile's ``world:`` section describes, validated before anything runs.

``parse_scene(profile)`` checks ``world:`` against its declaration
(``world_spec.WORLD``: every key's type and range, and what spans the keys of one
entry), then builds the :class:`SceneSpec` from the parsed values with ``tags:``,
``tracker:`` and ``obstacles:``, checking here only what needs the whole scene or
the rest of the profile: markers against ``tags:`` and their family, bodies off
the table or inside each other, routes off the table, spare bodies for
``randomize``. Every problem is a :class:`armtree.ConfigError` naming the entry
(``world.objects.NAME``) and, when the profile records where it came from, its
file, line and column.

Coordinates are the robot base frame in millimetres (z up, the table top at
``table.height``); yaw and headings are degrees in the file, radians in the scene.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from armtree.api.rig import TagSpec
from armtree.config.profile_access import profile_section
from armtree.errors import ConfigError
from armtree.loader.profile import Profile, tag_spec
from armtree.plugins.trackers.families import (
    HAMMING,
    MarkerFamily,
    apriltag_dictionary,
    family_named,
    max_corrected_bits,
    tracker_family,
)

from .as_built import AsBuilt
from .duckybot import DuckybotParams, Leg, RouteSpec
from .geometry import footprint_overlap, point_in_polygon
from .randomize import parse_randomize
from .scene_spec import (
    DuckybotSpec,
    LightSpec,
    MarkerSpec,
    ObjectSpec,
    PhysicsSpec,
    SceneSpec,
    SlipSpec,
    TableSpec,
)
from .world_parsing import _Errors, _vector, check_section, collected
from .world_spec import (
    AS_BUILT,
    AS_BUILT_CAMERA,
    BIN_WALL_MM,
    FAULTS,
    GAINS,
    KINDS,
    MISSED_STEPS,
    OBJECT,
    REFERENCE,
    WORLD,
    body_size,
)


@dataclass
class _Tags:
    """The profile's tag roles, and the marker family tagged bodies are drawn in: the one
    the profile's tracker reads (ArUco 4x4_50 for a tracker armtree does not know)."""

    specs: dict[str, TagSpec]
    drawn: MarkerFamily
    #: Bit corrections the hamming tracker allows (which Hampy ids are valid).
    corrections: int

    def ids(self, role: str | None, family: MarkerFamily | None = None) -> tuple[int, ...]:
        """The role's ids in ``family`` (the drawn one by default); none for no such role."""
        spec = self.specs.get(role or "")
        return () if spec is None else spec.in_family((family or self.drawn).name).ids

    def size(self, role: str) -> float:
        """The role's marker side (mm)."""
        return self.specs[role].size_mm

    def role_of(self, marker_id: int, family: MarkerFamily | None = None) -> str | None:
        """The role whose ids in ``family`` (the drawn one by default) include ``marker_id``."""
        for role in self.specs:
            if marker_id in self.ids(role, family):
                return role
        return None

    def in_drawn(self, marker_id: int) -> int:
        """``marker_id`` as the drawn family numbers it: a role's plain ``id`` / ``ids`` (as a
        ``world:`` entry writes it whatever the tracker) become that role's ids there."""
        for spec in self.specs.values():
            if marker_id in spec.ids and marker_id not in self.ids(spec.role):
                return self.ids(spec.role)[spec.ids.index(marker_id)]
        return marker_id


def _read_tags(profile: Profile) -> _Tags:
    specs: dict[str, TagSpec] = {}
    tags = profile_section(profile, "tags", {}) or {}
    if isinstance(tags, Mapping):
        for role, spec in tags.items():
            if isinstance(spec, Mapping):
                specs[str(role)] = tag_spec(str(role), {"size_mm": 25.0, **spec})
    tracker = profile_section(profile, "tracker", {}) or {}
    drawn = tracker_family(tracker)
    if drawn is None:
        dictionary = tracker.get("dictionary") if isinstance(tracker, Mapping) else None
        try:
            drawn = family_named(str(dictionary or "4x4_50"))
        except ConfigError:
            drawn = family_named("4x4_50")
    return _Tags(specs, drawn, max_corrected_bits(tracker))


def _marker_family(err: _Errors, path: tuple[Any, ...], spec: Mapping[str, Any], tags: _Tags):
    """The family a ``marker:`` entry is printed in: its ``family`` (``hamming``, ``aruco``
    with its ``dictionary``, ``apriltag``, or a dictionary's name), else the drawn one."""
    name = spec.get("family")
    dictionary = spec.get("dictionary")
    try:
        if name is None:
            return tags.drawn if dictionary is None else family_named(str(dictionary))
        if name == "aruco":
            default = tags.drawn.dictionary if tags.drawn.generator == "aruco" else "4x4_50"
            return family_named(str(dictionary or default))
        if name == "apriltag":
            return family_named(apriltag_dictionary(str(dictionary or "36h11")))
        return family_named(str(name))
    except ConfigError as exc:
        raise err((*path, "family" if name is not None else "dictionary"), str(exc)) from None


def _parse_marker(
    err: _Errors,
    path: tuple[Any, ...],
    value: Mapping[str, Any] | bool | None,
    kind: str,
    tags: _Tags,
    auto_index: int,
    top: tuple[float, float],
) -> MarkerSpec | None:
    """The marker of a checked ``marker:`` entry (None when absent, False for none) on a
    top face ``top`` (mm): its id and size from ``tags:``, in the family it is printed in."""
    role = KINDS[kind]["role"] if kind in KINDS else kind
    if value is False or (value is None and (role is None or role not in tags.specs)):
        return None
    spec: Mapping[str, Any] = value if isinstance(value, Mapping) else {}
    family = _marker_family(err, path, spec, tags)
    given = spec.get("id")
    if given is not None:
        mid = tags.in_drawn(given) if family.name == tags.drawn.name else given
    elif tags.ids(role, family):
        ids = tags.ids(role, family)
        mid = ids[auto_index % len(ids)]
    else:
        raise err(path, f"a {kind} marker needs an id (no tags: entry for role {role!r})")
    owner = tags.role_of(mid, family)
    # a spot is a printed sheet: its marker may be any role's (Durovic 2017's target marker)
    if kind == "spot" and owner is not None:
        role = owner
    if owner is not None and owner != role:
        raise err((*path, "id"), f"marker id {mid} is the {owner!r} tag in tags:, not a {kind}")
    if owner is None and role in tags.specs:
        raise err(
            (*path, "id"),
            f"{family.name} marker id {mid} is not among the {role!r} ids in tags: "
            f"{list(tags.ids(role, family))}",
        )
    size = spec.get("size_mm")
    if size is None:
        size = tags.size(role) if role in tags.specs else 25.0
    if owner is not None and abs(size - tags.size(owner)) > 1e-6:
        raise err(
            (*path, "size_mm"),
            f"marker side {size} mm differs from the {owner!r} tag size {tags.size(owner)} mm in tags:",
        )
    if size > min(top) + 1e-6:
        raise err(
            (*path, "size_mm"), f"a {size} mm marker does not fit on a {top[0]} x {top[1]} mm top"
        )
    # the sim draws no marker its family's tracker could not read (docs/trackers.md)
    corrections = tags.corrections if family.generator == HAMMING else 0
    problem = family.id_error(int(mid), corrections)
    if problem is not None:
        raise err((*path, "id") if given is not None else path, problem)
    return MarkerSpec(
        family=family.generator,
        id=int(mid),
        size_mm=float(size),
        dictionary=family.dictionary or "4x4_50",
        role=owner if owner is not None else role,
    )


def _parse_body(
    err: _Errors,
    path: tuple[Any, ...],
    name: str,
    entry: Mapping[str, Any],
    kind: str,
    tags: _Tags,
    auto_index: dict[str, int],
    table: TableSpec,
) -> ObjectSpec:
    """The body a checked entry (``OBJECT.parse``'s, or a Duckybot's) describes, with its
    kind's size and colour unless it gives them, standing on the table unless ``at`` gives
    z, and the next marker of its tag role unless ``marker`` says otherwise."""
    shape = entry.get("shape") or "box"
    size = body_size(kind, shape, entry.get("size"))
    at = entry["at"]
    color = entry.get("color") or KINDS[kind]["color"]
    wall = entry.get("wall_mm")
    role = KINDS[kind]["role"]
    index = auto_index.get(role or kind, 0)
    marker = None
    if kind not in ("bin", "spot") or entry.get("marker") is not None:
        top = (size[0], size[1])
        marker = _parse_marker(err, (*path, "marker"), entry.get("marker"), kind, tags, index, top)
    auto_index[role or kind] = index + 1
    return ObjectSpec(
        name=name,
        kind=kind,
        shape=shape,
        size=np.array(size, dtype=float),
        position=np.array([at[0], at[1], at[2] if len(at) == 3 else table.height], dtype=float),
        yaw=math.radians(entry.get("yaw") or 0.0),
        color=(int(color[0]), int(color[1]), int(color[2])),
        marker=marker,
        wall=float((BIN_WALL_MM if kind == "bin" else 0.0) if wall is None else wall),
    )


def _leg(leg: Any) -> Leg:
    """One checked leg of a route: ``(x, y)``, ``{drive_to}`` or ``{park, ...}`` (mm, degrees)."""
    if isinstance(leg, tuple):
        return Leg("drive", (leg[0], leg[1]))
    if leg["drive_to"] is not None:
        return Leg("drive", (leg["drive_to"][0], leg["drive_to"][1]))
    park = leg["park"]
    timeout = math.inf if leg["timeout_s"] is None else leg["timeout_s"]
    heading = math.radians(park[2]) if len(park) == 3 else None
    return Leg("park", (park[0], park[1]), heading, leg["until"], leg["wait_s"], timeout)


def _parse_duckybot(
    err: _Errors,
    path: tuple[Any, ...],
    name: str,
    bot: Mapping[str, Any],
    tags: _Tags,
    auto_index: dict[str, int],
    table: TableSpec,
) -> DuckybotSpec:
    """A checked Duckybot entry (``DUCKYBOT.parse``'s): its body at its start, its route,
    which must stay on the table, and its controller."""
    start = bot["start"]
    heading = math.radians(start[2]) if len(start) == 3 else 0.0
    route = RouteSpec(
        (start[0], start[1], heading), [_leg(leg) for leg in bot["route"]], bot["loop"]
    )
    body_entry = {k: bot[k] for k in ("size", "color", "marker")}
    body_entry |= {"at": route.start[:2], "yaw": math.degrees(route.start[2])}
    body = _parse_body(err, path, name, body_entry, "duckybot", tags, auto_index, table)
    gains = bot["gains"] or GAINS.parse({})
    params = DuckybotParams(
        speed=bot["speed_mm_s"],
        turn_rate=math.radians(bot["turn_deg_s"]),
        kp=gains["kp"],
        ktheta=gains["ktheta"],
        max_speed=bot["max_speed_mm_s"],
        noise=bot["noise"],
    )
    for i, leg in enumerate(route.legs):
        if not point_in_polygon(np.array(leg.target), table.polygon()):
            raise err((*path, "route", i), f"route point {list(leg.target)} is off the table")
    return DuckybotSpec(body=body, route=route, params=params)


def _profile_obstacles(err: _Errors, profile: Profile, table: TableSpec) -> list[ObjectSpec]:
    out = []
    for i, entry in enumerate(profile_section(profile, "obstacles", []) or []):
        box = entry.get("box") if isinstance(entry, Mapping) else None
        if not isinstance(box, Mapping):
            continue
        center = _vector(err, ("obstacles", i, "box", "center"), box.get("center"), (3,))
        size = _vector(err, ("obstacles", i, "box", "size"), box.get("size"), (3,))
        out.append(
            ObjectSpec(
                name=f"obstacles[{i}]",
                kind="obstacle",
                shape="box",
                size=np.array(size),
                position=np.array([center[0], center[1], center[2] - size[2] / 2]),
                yaw=0.0,
                color=KINDS["obstacle"]["color"],
                marker=None,
            )
        )
    return out


def parse_scene(profile: Profile) -> SceneSpec:
    """Validate the profile's ``world:`` section and return the scene it describes.

    Raises :class:`armtree.ConfigError` listing every value :data:`WORLD` refuses
    (unknown keys, kinds, shapes, values of the wrong type or range), else naming the
    first entry the whole scene refuses: objects off the table or inside each other,
    routes off the table, markers whose id or size clashes with the profile's ``tags:``
    or that its family cannot carry.
    """
    err = _Errors(profile)
    errors = check_section(profile, "world", WORLD)
    if errors:
        raise collected(errors)
    raw = profile_section(profile, "world") or {}
    world = WORLD.parse(raw)
    tags = _read_tags(profile)
    table = world["table"] or TableSpec()
    auto_index: dict[str, int] = {}
    objects = [
        _parse_body(
            err,
            ("world", "objects", name),
            str(name),
            entry,
            entry["kind"],
            tags,
            auto_index,
            table,
        )
        for name, entry in world["objects"].items()
    ]
    duckybots = [
        _parse_duckybot(err, ("world", "duckybots", name), name, bot, tags, auto_index, table)
        for name, bot in world["duckybots"].items()
    ]

    def spare(kind: str, name: str, path: tuple[Any, ...], index: int) -> ObjectSpec:
        """One more body of ``kind`` for ``randomize``'s count, like the first one."""
        first = next(o for o in objects if o.kind == kind)
        role = KINDS[kind]["role"]
        ids = tags.ids(role) if first.marker is not None else ()
        if first.marker is not None and index >= len(ids):
            raise err(
                path, f"tags.{role} has {len(ids)} marker ids: at most {len(ids)} {kind} bodies"
            )
        entry = {
            "kind": kind,
            "shape": first.shape,
            "size": first.size.tolist(),
            "at": first.position[:2].tolist(),
            "color": list(first.color),
            "marker": None if first.marker is not None else False,
        }
        return _parse_body(err, path, name, OBJECT.parse(entry), kind, tags, auto_index, table)

    randomize = parse_randomize(err, world["randomize"], objects, duckybots, spare)
    objects += _profile_obstacles(err, profile, table)
    _check_layout(err, table, objects + [b.body for b in duckybots])
    faults, slips = _parse_faults(raw.get("faults"))
    tool_marker, tool_offset = None, np.zeros(3)
    if world["tool_marker"] is not None:
        marker_entry = {k: v for k, v in world["tool_marker"].items() if k != "offset"}
        tool_offset = np.array(world["tool_marker"]["offset"])
        tool_marker = _parse_marker(
            err, ("world", "tool_marker"), marker_entry, "tool", tags, 0, (1e9, 1e9)
        )
    return SceneSpec(
        seed=world["seed"],
        table=table,
        objects=objects,
        duckybots=duckybots,
        faults=faults,
        physics=world["physics"] or PhysicsSpec(),
        light=world["light"] or LightSpec(),
        tool_marker=tool_marker,
        tool_marker_offset=tool_offset,
        slips=slips,
        randomize=randomize,
        as_built=_as_built(world["as_built"], world["reference"]),
    )


def _check_layout(err: _Errors, table: TableSpec, bodies: list[ObjectSpec]) -> None:
    """Every body on the table and no two inside each other (bins may hold things)."""
    poly = table.polygon()
    for b in bodies:
        path = _body_path(b)
        if not all(point_in_polygon(c, poly) for c in b.footprint()):
            raise err(
                path,
                f"{b.name} at {b.position[:2].tolist()} mm is (partly) off the table "
                f"x {list(table.x)}, y {list(table.y)}",
            )
        if b.position[2] < table.height - 1e-6:
            raise err(path, f"{b.name} is below the table top (z {b.position[2]} < {table.height})")
    for i, a in enumerate(bodies):
        for b in bodies[i + 1 :]:
            if "spot" in (a.kind, b.kind):
                continue
            za = (a.position[2], a.position[2] + a.size[2])
            zb = (b.position[2], b.position[2] + b.size[2])
            if za[1] <= zb[0] + 1e-6 or zb[1] <= za[0] + 1e-6:
                continue
            if not footprint_overlap(a.footprint(), b.footprint()):
                continue
            if _inside_bin(a, b) or _inside_bin(b, a):
                continue
            raise err(
                _body_path(b), f"{b.name} overlaps {a.name}: objects cannot be inside each other"
            )


def _inside_bin(container: ObjectSpec, item: ObjectSpec) -> bool:
    if container.kind != "bin":
        return False
    wall = 2 * container.wall
    inner = dataclasses.replace(container, size=container.size - np.array([wall, wall, 0.0]))
    return (
        all(point_in_polygon(c, inner.footprint()) for c in item.footprint())
        and item.position[2] >= container.position[2] + container.wall - 1e-6
    )


def body_error(profile: Profile, body: ObjectSpec, message: str) -> ConfigError:
    """A ConfigError about one body of the world, at its entry in the profile."""
    return _Errors(profile)(_body_path(body), message)


def _body_path(body: ObjectSpec) -> tuple[Any, ...]:
    if body.name.startswith("obstacles["):
        return ("obstacles", int(body.name[len("obstacles[") : -1]))
    group = "duckybots" if body.kind == "duckybot" else "objects"
    return ("world", group, body.name)


def _parse_faults(value: Any) -> tuple[dict[str, dict[str, float]], SlipSpec | None]:
    """Checked ``world.faults``: the one-shot faults for the emulator's ``inject`` with
    the options given (in the file's order), and random missed steps under load."""
    out: dict[str, dict[str, float]] = {}
    slips = None
    for name, options in (value or {}).items():
        if options is None or options is False:
            continue
        options = {} if options is True else options
        if name == "missed_steps" and options.get("rate_per_s") is not None:
            load = MISSED_STEPS.parse(options)
            slips = SlipSpec(load["rate_per_s"], load["max_amount"], load["joints"])
            continue
        fields = FAULTS.fields[name].parse(options)
        out[str(name)] = {str(k): fields[k] for k, v in options.items() if v is not None}
    return out, slips


def _as_built(built: Mapping[str, Any] | None, reference: Mapping[str, Any] | None) -> AsBuilt:
    """Checked ``world.as_built`` and ``world.reference`` (either may be absent)."""
    built = built or AS_BUILT.parse({})
    camera = built["camera"] or AS_BUILT_CAMERA.parse({})
    noise = (reference or REFERENCE.parse({}))["noise_mm"]
    return AsBuilt(camera["offset_mm"], camera["rotation_deg"], dict(built["arm"]), noise)
