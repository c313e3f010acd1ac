"""The scene a profile's ``world:`` section describes, validated before anything runs.

``parse_scene(profile)`` reads ``world:`` (plus ``tags:``, ``tracker:`` and
``obstacles:``) and returns a :class:`SceneSpec`; every problem is a
:class:`armtree.ConfigError` naming the entry (``world.objects.NAME``) and,
when the profile records where it came from, its file, line and column.

Coordinates are the robot base frame in millimetres (z up, the table top at
``table.height``); yaw and headings are degrees in the file.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from armtree.api.rig import TagSpec
from armtree.config.profile_access import profile_section
from armtree.errors import ConfigError, did_you_mean, shown
from armtree.loader.profile import Profile, tag_spec
from armtree.plugins.trackers.families import (
    HAMMING,
    MarkerFamily,
    apriltag_dictionary,
    family_named,
    max_corrected_bits,
    tracker_family,
)

from .as_built import parse_as_built
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
from .world_parsing import _Errors, _mapping, _number, _vector

#: Object kinds, their default shape, size (mm), colour (BGR) and tag role.
KINDS: dict[str, dict[str, Any]] = {
    "ducky": {"size": (32.0, 32.0, 30.0), "color": (40, 205, 250), "role": "ducky"},
    "trash": {"size": (30.0, 30.0, 20.0), "color": (90, 110, 130), "role": "trash"},
    "block": {"size": (30.0, 30.0, 25.0), "color": (60, 90, 200), "role": "block"},
    "obstacle": {"size": (60.0, 60.0, 80.0), "color": (120, 70, 40), "role": "obstacle"},
    "bin": {"size": (90.0, 90.0, 35.0), "color": (60, 110, 50), "role": None},
    "spot": {"size": (50.0, 50.0, 0.0), "color": (200, 200, 215), "role": None},
    "duckybot": {"size": (90.0, 70.0, 40.0), "color": (50, 50, 60), "role": "duckybot"},
}
SHAPES = ("box", "cylinder")

_OBJECT_KEYS = ("kind", "shape", "size", "at", "yaw", "color", "marker", "wall_mm", "mass_g")
_DUCKYBOT_KEYS = (
    "size",
    "color",
    "marker",
    "start",
    "route",
    "loop",
    "speed_mm_s",
    "turn_deg_s",
    "gains",
    "noise",
    "max_speed_mm_s",
)
_WORLD_KEYS = (
    "seed",
    "table",
    "objects",
    "duckybots",
    "faults",
    "physics",
    "light",
    "tool_marker",
    "randomize",
    "as_built",
    "reference",
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
    value: Any,
    kind: str,
    tags: _Tags,
    auto_index: int,
    top: tuple[float, float],
) -> MarkerSpec | None:
    role = KINDS[kind]["role"] if kind in KINDS else kind
    if value is False or (value is None and (role is None or role not in tags.specs)):
        return None
    if value is None:
        value = {}
    spec = _mapping(err, path, value, ("id", "size_mm", "family", "dictionary"))
    family = _marker_family(err, path, spec, tags)
    drawn = family.name == tags.drawn.name
    if "id" in spec:
        mid = spec["id"]
        if isinstance(mid, bool) or not isinstance(mid, int) or mid < 0:
            raise err((*path, "id"), f"expected a marker id (integer >= 0), got {mid!r}")
        if drawn:
            mid = tags.in_drawn(mid)
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
    size = _number(err, (*path, "size_mm"), size, positive=True)
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
        raise err((*path, "id") if "id" in spec else path, problem)
    return MarkerSpec(
        family=family.generator,
        id=int(mid),
        size_mm=size,
        dictionary=family.dictionary or "4x4_50",
        role=owner if owner is not None else role,
    )


def _parse_body(
    err: _Errors,
    path: tuple[Any, ...],
    name: str,
    entry: Any,
    tags: _Tags,
    auto_index: dict[str, int],
    table: TableSpec,
    forced_kind: str | None = None,
    keys: Sequence[str] = _OBJECT_KEYS,
) -> ObjectSpec:
    entry = _mapping(err, path, entry, keys)
    kind = forced_kind or entry.get("kind")
    if kind is None:
        raise err(path, f"missing 'kind' (one of {', '.join(k for k in KINDS if k != 'duckybot')})")
    if kind not in KINDS or (forced_kind is None and kind == "duckybot"):
        hint = did_you_mean(str(kind), KINDS, list_up_to=len(KINDS))
        what = (
            "duckybots go under world.duckybots"
            if kind == "duckybot"
            else f"unknown kind {kind!r}{hint}"
        )
        raise err((*path, "kind"), what)
    shape = entry.get("shape", "box")
    if shape not in SHAPES:
        raise err((*path, "shape"), f"unknown shape {shape!r}; expected one of {', '.join(SHAPES)}")
    default_size = KINDS[kind]["size"]
    size_value = entry.get("size", default_size)
    size = _vector(err, (*path, "size"), size_value, (3, 2) if shape == "cylinder" else (3,))
    if shape == "cylinder" and len(size) == 2:
        size = [size[0], size[0], size[1]]
    if min(size[:2]) <= 0 or size[2] < 0 or (size[2] == 0 and kind != "spot"):
        raise err((*path, "size"), f"sizes must be positive, got {size_value!r}")
    at = entry.get("at")
    if at is None:
        raise err(path, "missing 'at': the position [x, y] (mm) on the table")
    at_v = _vector(err, (*path, "at"), at, (2, 3))
    z = at_v[2] if len(at_v) == 3 else table.height
    yaw = math.radians(_number(err, (*path, "yaw"), entry.get("yaw", 0.0)))
    color = entry.get("color", KINDS[kind]["color"])
    color_v = _vector(err, (*path, "color"), color, (3,))
    wall = _number(err, (*path, "wall_mm"), entry.get("wall_mm", 3.0 if kind == "bin" else 0.0))
    if kind == "bin" and not 0 < wall < min(size[:2]) / 2:
        raise err((*path, "wall_mm"), f"wall {wall} mm does not fit a {size[0]} x {size[1]} mm bin")
    role = KINDS[kind]["role"]
    index = auto_index.get(role or kind, 0)
    marker = None
    if kind not in ("bin", "spot") or "marker" in entry:
        marker = _parse_marker(
            err,
            (*path, "marker"),
            entry.get("marker"),
            kind,
            tags,
            index,
            (size[0], size[1]),
        )
    auto_index[role or kind] = index + 1
    return ObjectSpec(
        name=name,
        kind=kind,
        shape=shape,
        size=np.array(size, dtype=float),
        position=np.array([at_v[0], at_v[1], z], dtype=float),
        yaw=yaw,
        color=(int(color_v[0]), int(color_v[1]), int(color_v[2])),
        marker=marker,
        wall=wall,
    )


def _parse_route(err: _Errors, path: tuple[Any, ...], entry: Mapping[str, Any]) -> RouteSpec:
    start = _vector(err, (*path, "start"), entry.get("start", [0, 0, 0]), (2, 3))
    heading = math.radians(start[2]) if len(start) == 3 else 0.0
    legs: list[Leg] = []
    route = entry.get("route", [])
    if not isinstance(route, Sequence) or isinstance(route, (str, bytes)):
        raise err((*path, "route"), f"expected a list of legs, got {route!r}")
    for i, leg in enumerate(route):
        lp = (*path, "route", i)
        if isinstance(leg, Sequence) and not isinstance(leg, (str, bytes)):
            xy = _vector(err, lp, leg, (2,))
            legs.append(Leg("drive", (xy[0], xy[1])))
            continue
        spec = _mapping(err, lp, leg, ("drive_to", "park", "until", "wait_s", "timeout_s"))
        if ("drive_to" in spec) == ("park" in spec):
            raise err(lp, "a leg is [x, y], {drive_to: [x, y]} or {park: [x, y, heading_deg], ...}")
        if "drive_to" in spec:
            xy = _vector(err, (*lp, "drive_to"), spec["drive_to"], (2,))
            legs.append(Leg("drive", (xy[0], xy[1])))
            continue
        target = _vector(err, (*lp, "park"), spec["park"], (2, 3))
        until = spec.get("until", "loaded")
        if until not in ("loaded", "time"):
            raise err((*lp, "until"), f"expected 'loaded' or 'time', got {until!r}")
        wait = _number(err, (*lp, "wait_s"), spec.get("wait_s", 1.0))
        timeout = math.inf
        if spec.get("timeout_s") is not None:
            timeout = _number(err, (*lp, "timeout_s"), spec["timeout_s"], positive=True)
        legs.append(
            Leg(
                "park",
                (target[0], target[1]),
                math.radians(target[2]) if len(target) == 3 else None,
                until,
                wait,
                timeout,
            )
        )
    loop = entry.get("loop", False)
    if not isinstance(loop, bool):
        raise err((*path, "loop"), f"expected true or false, got {loop!r}")
    return RouteSpec((start[0], start[1], heading), legs, loop)


def _parse_duckybot(
    err: _Errors,
    path: tuple[Any, ...],
    name: str,
    entry: Any,
    tags: _Tags,
    auto_index: dict[str, int],
    table: TableSpec,
) -> DuckybotSpec:
    entry = _mapping(err, path, entry, _DUCKYBOT_KEYS)
    route = _parse_route(err, path, entry)
    body_entry = {k: entry[k] for k in ("size", "color", "marker") if k in entry}
    body_entry["at"] = list(route.start[:2])
    body_entry["yaw"] = math.degrees(route.start[2])
    body = _parse_body(err, path, name, body_entry, tags, auto_index, table, forced_kind="duckybot")
    gains = _mapping(err, (*path, "gains"), entry.get("gains"), ("kp", "ktheta"))
    params = DuckybotParams(
        speed=_number(err, (*path, "speed_mm_s"), entry.get("speed_mm_s", 50.0), positive=True),
        turn_rate=math.radians(
            _number(err, (*path, "turn_deg_s"), entry.get("turn_deg_s", 90.0), positive=True)
        ),
        kp=_number(err, (*path, "gains", "kp"), gains.get("kp", 2.0), positive=True),
        ktheta=_number(err, (*path, "gains", "ktheta"), gains.get("ktheta", 4.0), positive=True),
        max_speed=_number(
            err, (*path, "max_speed_mm_s"), entry.get("max_speed_mm_s", 120.0), positive=True
        ),
        noise=_number(err, (*path, "noise"), entry.get("noise", 0.03)),
    )
    for i, leg in enumerate(route.legs):
        if not point_in_polygon(np.array(leg.target), table.polygon()):
            raise err((*path, "route", i), f"route point {list(leg.target)} is off the table")
    return DuckybotSpec(body=body, route=route, params=params)


def _parse_table(err: _Errors, value: Any) -> TableSpec:
    spec = _mapping(err, ("world", "table"), value, ("x", "y", "height", "texture"))
    t = TableSpec()
    x = _vector(err, ("world", "table", "x"), spec.get("x", list(t.x)), (2,))
    y = _vector(err, ("world", "table", "y"), spec.get("y", list(t.y)), (2,))
    if x[0] >= x[1] or y[0] >= y[1]:
        raise err(("world", "table"), "x and y must be [min, max] with min < max")
    texture = spec.get("texture", t.texture)
    if texture not in ("wood", "plain", "checker"):
        raise err(
            ("world", "table", "texture"), f"unknown texture {texture!r}; wood, plain or checker"
        )
    height = _number(err, ("world", "table", "height"), spec.get("height", t.height))
    return TableSpec((x[0], x[1]), (y[0], y[1]), height, str(texture))


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

    Raises :class:`armtree.ConfigError` naming the entry for unknown keys,
    kinds or shapes, objects off the table or inside each other, and markers
    whose id or size clashes with the profile's ``tags:``.
    """
    err = _Errors(profile)
    world = _mapping(err, ("world",), profile_section(profile, "world", {}), _WORLD_KEYS)
    tags = _read_tags(profile)
    table = _parse_table(err, world.get("table"))
    seed = world.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**63:
        raise err(("world", "seed"), f"expected an integer from 0 to 2**63 - 1, got {shown(seed)}")
    auto_index: dict[str, int] = {}
    objects: list[ObjectSpec] = []
    entries = world.get("objects") or {}
    if not isinstance(entries, Mapping):
        raise err(("world", "objects"), "expected a mapping of name: {kind: ..., at: [x, y]}")
    for name, entry in entries.items():
        objects.append(
            _parse_body(err, ("world", "objects", name), str(name), entry, tags, auto_index, table)
        )
    bots_entry = world.get("duckybots") or {}
    if not isinstance(bots_entry, Mapping):
        raise err(("world", "duckybots"), "expected a mapping of name: {route: [...], ...}")
    duckybots = [
        _parse_duckybot(
            err, ("world", "duckybots", name), str(name), entry, tags, auto_index, table
        )
        for name, entry in bots_entry.items()
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
        }
        if first.marker is None:
            entry["marker"] = False
        return _parse_body(err, path, name, entry, tags, auto_index, table)

    randomize = parse_randomize(err, world.get("randomize"), objects, duckybots, spare)
    objects += _profile_obstacles(err, profile, table)
    _check_layout(err, table, objects + [b.body for b in duckybots])
    faults, slips = _parse_faults(err, world.get("faults"))
    physics = _parse_physics(err, world.get("physics"))
    light = _parse_light(err, world.get("light"))
    tool_marker, tool_offset = None, np.zeros(3)
    if world.get("tool_marker") is not None:
        tm = _mapping(
            err,
            ("world", "tool_marker"),
            world["tool_marker"],
            ("id", "size_mm", "family", "dictionary", "offset"),
        )
        tool_offset = np.array(
            _vector(err, ("world", "tool_marker", "offset"), tm.get("offset", [0, 0, 20]), (3,))
        )
        marker_entry = {k: v for k, v in tm.items() if k != "offset"}
        tool_marker = _parse_marker(
            err, ("world", "tool_marker"), marker_entry, "tool", tags, 0, (1e9, 1e9)
        )
    return SceneSpec(
        seed=seed,
        table=table,
        objects=objects,
        duckybots=duckybots,
        faults=faults,
        physics=physics,
        light=light,
        tool_marker=tool_marker,
        tool_marker_offset=tool_offset,
        slips=slips,
        randomize=randomize,
        as_built=parse_as_built(err, world),
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


def _parse_faults(err: _Errors, value: Any) -> tuple[dict[str, dict[str, float]], SlipSpec | None]:
    """One-shot faults for the emulator's ``inject``, and random missed steps under load."""
    spec = _mapping(err, ("world", "faults"), value, tuple(_FAULT_OPTIONS))
    out: dict[str, dict[str, float]] = {}
    slips = None
    for name, options in spec.items():
        path = ("world", "faults", name)
        if options is None or options is False:
            continue
        if options is True:
            options = {}
        if not isinstance(options, Mapping):
            raise err(path, f"expected a mapping of options, got {options!r}")
        if name == "missed_steps" and "rate_per_s" in options:
            options = _mapping(err, path, options, ("rate_per_s", "max_amount", "joints"))
            joints = options.get("joints", [])
            if not isinstance(joints, Sequence) or not all(
                isinstance(j, int) and not isinstance(j, bool) and j >= 0 for j in joints
            ):
                raise err((*path, "joints"), f"expected a list of joint indices, got {joints!r}")
            slips = SlipSpec(
                rate=_number(err, (*path, "rate_per_s"), options["rate_per_s"], positive=True),
                max_amount=_number(
                    err, (*path, "max_amount"), options.get("max_amount", 2.0), positive=True
                ),
                joints=tuple(int(j) for j in joints),
            )
            continue
        out[name] = _one_shot(err, path, name, options)
    return out, slips


#: Options of each one-shot fault (``PtyEmulator.inject``) and the range of each, inclusive.
_FAULT_OPTIONS: dict[str, dict[str, tuple[float, float]]] = {
    "corrupt": {"rate": (0.0, 1.0), "count": (0, 1e9)},
    "drop": {"rate": (0.0, 1.0), "count": (0, 1e9)},
    "cut": {"silent": (0, 1)},
    "missed_steps": {"joint": (0, 63), "amount": (-360.0, 360.0)},
    # servo buses (the arm's factory lists the faults its emulator takes: ``faults``)
    "lost_replies": {"rate": (0.0, 1.0), "count": (0, 1e9)},
    "latency": {"seconds": (0.0, 10.0)},
    "overload": {"joint": (0, 63), "id": (0, 252), "after_s": (0.0, 1e6)},
    "overheat": {"joint": (0, 63), "id": (0, 252), "after_s": (0.0, 1e6)},
}
#: The faults every arm emulator takes (an arm factory's ``faults`` may list more).
BASE_FAULTS = ("missed_steps", "corrupt", "drop", "cut")


def _one_shot(err: _Errors, path: tuple[Any, ...], name: str, options: Mapping) -> dict[str, float]:
    allowed = _FAULT_OPTIONS[name]
    _mapping(err, path, options, tuple(allowed))
    if name == "missed_steps" and "amount" not in options:
        raise err(path, "needs amount: how far the joint slips (degrees, or mm on a linear axis)")
    out = {}
    for key, value in options.items():
        low, high = allowed[key]
        number = _number(err, (*path, key), value)
        if not low <= number <= high:
            raise err(
                (*path, key), f"expected a number from {low:g} to {high:g}, got {shown(value)}"
            )
        out[str(key)] = number
    return out


def _parse_physics(err: _Errors, value: Any) -> PhysicsSpec:
    spec = _mapping(
        err,
        ("world", "physics"),
        value,
        ("pick_tolerance_mm", "collision_tolerance_mm", "halt_on_collision", "gripper_mm_per_unit"),
    )
    p = PhysicsSpec()
    halt = spec.get("halt_on_collision", p.halt_on_collision)
    if not isinstance(halt, bool):
        raise err(
            ("world", "physics", "halt_on_collision"), f"expected true or false, got {halt!r}"
        )
    return PhysicsSpec(
        pick_tolerance_mm=_number(
            err,
            ("world", "physics", "pick_tolerance_mm"),
            spec.get("pick_tolerance_mm", p.pick_tolerance_mm),
            positive=True,
        ),
        collision_tolerance_mm=_number(
            err,
            ("world", "physics", "collision_tolerance_mm"),
            spec.get("collision_tolerance_mm", p.collision_tolerance_mm),
        ),
        halt_on_collision=halt,
        gripper_mm_per_unit=_number(
            err,
            ("world", "physics", "gripper_mm_per_unit"),
            spec.get("gripper_mm_per_unit", p.gripper_mm_per_unit),
            positive=True,
        ),
    )


def _parse_light(err: _Errors, value: Any) -> LightSpec:
    spec = _mapping(err, ("world", "light"), value, ("position", "ambient"))
    d = LightSpec()
    pos = _vector(err, ("world", "light", "position"), spec.get("position", list(d.position)), (3,))
    ambient = _number(err, ("world", "light", "ambient"), spec.get("ambient", d.ambient))
    if not 0 <= ambient <= 1:
        raise err(("world", "light", "ambient"), f"must be between 0 and 1, got {ambient}")
    return LightSpec((pos[0], pos[1], pos[2]), ambient)
