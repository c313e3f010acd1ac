"""Randomised worlds: ``--seed N`` draws a world from the ranges in ``world.randomize:``.

Seed 0 is the profile's nominal world; every other seed draws, deterministically
for the seed, where objects lie and which way they face, how many trash there
are, where the Duckybot parks, the lamp, the camera's noise, blur and frame
drops, and the rate of missed steps::

    world:
      randomize:
        objects:
          ducky: {on: ducky_spot, yaw: [-180, 180]}      # wholly on its spot, any heading
          trash: {count: [1, 3], ring: {r: [172, 198], angle: [-100, 100]}, yaw: [-180, 180]}
        duckybots:
          duckybot: {park: {ring: {r: [168, 186], angle: [-95, 95]}, heading: [-30, 30]}}
        light: {x: [0, 300], y: [-400, -100], z: [700, 1100], ambient: [0.45, 0.7]}
        camera: {noise: [1.5, 4], blur: [0.3, 0.9], drop_rate: [0, 0.04]}
        faults: {missed_steps: {rate_per_s: [0, 0.03], max_amount: 0.5}}
        gap_mm: 5

An object entry names a body, or a kind (``trash``) for every body of it,
and one region: ``on: SPOT`` (its footprint wholly on a spot), ``ring: {r: [MIN,
MAX], angle: [MIN, MAX]}`` (mm, degrees about the arm's base) or ``region: {x:
[MIN, MAX], y: [MIN, MAX]}`` (mm). ``count: [MIN, MAX]`` (kinds only) draws how
many there are: the profile's own bodies first, then more named ``kind_c``,
``kind_d``..., with the next marker ids of their tag role; past MIN, a body the
region has no room left for is left out (the world has fewer of the kind). A Duckybot's ``park``
draws its parking point (``ring`` or ``region``) and turns its heading by up to
``heading`` degrees; its whole route turns with it about the arm's base (a
ring) or moves with it (a region). A range is ``[MIN, MAX]``; a single number
is fixed.

Every drawn world is valid: bodies on the table, ``gap_mm`` apart and clear of
the Duckybots' routes (spots, bins and obstacles included: a Duckybot does not
drive over the spot a ducky is drawn on; a body ``on`` a spot lies on it),
routes on the table. A profile whose ranges leave no room for a body it must
have is refused when the world is drawn, naming the entry. That the regions are
reachable and seen by the camera is the profile's business: the shipped sim
profiles' tests check it over many seeds.
"""

from __future__ import annotations

import dataclasses
import math
import string
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from armtree.config.spec import unknown_hint

from .duckybot import RouteSpec
from .geometry import footprint_overlap, point_in_polygon
from .scene_spec import DuckybotSpec, LightSpec, ObjectSpec, SceneSpec, SlipSpec
from .world_parsing import _Errors

#: Attempts to place one body before the profile is refused.
TRIES = 400

Range = tuple[float, float]


@dataclass(frozen=True)
class Region:
    """Where a point is drawn: ``kind`` ``on`` (a spot's name in ``spot``), ``ring`` or ``region``."""

    kind: str
    a: Range = (0.0, 0.0)  # ring: r (mm); region: x (mm)
    b: Range = (0.0, 0.0)  # ring: angle (degrees); region: y (mm)
    spot: str = ""


@dataclass(frozen=True)
class ObjectDraw:
    """How one body (or every body of a kind) is drawn; ``path`` is its entry, for errors."""

    target: str
    region: Region
    yaw: Range | None
    count: tuple[int, int] | None
    path: tuple[Any, ...]


@dataclass(frozen=True)
class ParkDraw:
    """How a Duckybot's parking point and heading are drawn."""

    name: str
    region: Region
    heading: Range
    path: tuple[Any, ...]


@dataclass
class RandomizeSpec:
    """``world.randomize:`` parsed. ``spares`` are the extra bodies ``count`` may add, by kind."""

    objects: list[ObjectDraw] = field(default_factory=list)
    parks: list[ParkDraw] = field(default_factory=list)
    light: dict[str, Range] = field(default_factory=dict)
    camera: dict[str, Range] = field(default_factory=dict)
    slips: dict[str, Any] | None = None
    gap_mm: float = 5.0
    spares: dict[str, list[ObjectSpec]] = field(default_factory=dict)


# ---------------------------------------------------------------------------
# Parsing (called by parse_scene, so armtree check reports mistakes)
# ---------------------------------------------------------------------------


def _region(value: Mapping[str, Any]) -> Region:
    """The one region of a checked draw (:data:`.randomize_spec.OBJECT_DRAW`, ``PARK``)."""
    if value.get("on") is not None:
        return Region("on", spot=str(value["on"]))
    if value.get("ring") is not None:
        return Region("ring", value["ring"]["r"], value["ring"]["angle"])
    return Region("region", value["region"]["x"], value["region"]["y"])


def _named(err: _Errors, path: tuple[Any, ...], name: Any, known: Sequence[str], noun: str) -> None:
    if name not in known:
        raise err((*path, name), f"unknown {noun} {name!r}{unknown_hint(name, tuple(known))}")


def parse_randomize(
    err: _Errors,
    value: Mapping[str, Any] | None,
    objects: list[ObjectSpec],
    duckybots: list[DuckybotSpec],
    spare: Any,
) -> RandomizeSpec | None:
    """``world.randomize`` as :data:`.randomize_spec.RANDOMIZE` parsed it, checked against
    the world's bodies; ``spare(kind, name, path, index)`` parses an extra body of a kind."""
    if value is None:
        return None
    root = ("world", "randomize")
    out = RandomizeSpec()
    names = {o.name: o for o in objects}
    kinds = sorted({o.kind for o in objects})
    spots = {o.name for o in objects if o.kind == "spot"}
    for target, entry in value["objects"].items():
        path = (*root, "objects", target)
        _named(err, (*root, "objects"), target, [*names, *kinds], "body or kind")
        region = _region(entry)
        if region.kind == "on" and region.spot not in spots:
            raise err((*path, "on"), f"no spot {region.spot!r} in world.objects (kind: spot)")
        count = None
        if entry["count"] is not None:
            if target in names:
                raise err(
                    (*path, "count"), f"count is for a kind (e.g. trash), not the body {target!r}"
                )
            count = (int(entry["count"][0]), int(entry["count"][1]))
            have = [o for o in objects if o.kind == target]
            out.spares[target] = [
                spare(target, _spare_name(target, names, i), (*path, "count"), len(have) + i)
                for i in range(max(0, count[1] - len(have)))
            ]
        out.objects.append(ObjectDraw(str(target), region, entry["yaw"], count, path))
    bots = sorted(b.body.name for b in duckybots)
    for name, entry in value["duckybots"].items():
        path = (*root, "duckybots", name)
        _named(err, (*root, "duckybots"), name, bots, "Duckybot")
        if not any(
            leg.kind == "park" for b in duckybots if b.body.name == name for leg in b.route.legs
        ):
            raise err(path, f"the Duckybot {name!r} has no park leg in its route to move")
        park = entry["park"]
        out.parks.append(ParkDraw(str(name), _region(park), park["heading"], path))
    out.light = {k: v for k, v in (value["light"] or {}).items() if v is not None}
    out.camera = {k: v for k, v in (value["camera"] or {}).items() if v is not None}
    slips = (value["faults"] or {}).get("missed_steps")
    if slips is not None:
        out.slips = {
            "rate": slips["rate_per_s"],
            "max_amount": slips["max_amount"],
            "joints": tuple(int(j) for j in slips["joints"] or ()),
        }
    out.gap_mm = value["gap_mm"]
    return out


def _spare_name(kind: str, taken: Mapping[str, Any], index: int) -> str:
    """The ``index``-th free name ``kind_c``, ``kind_d``, ... (``kind_27`` past z)."""
    free = [f"{kind}_{c}" for c in string.ascii_lowercase if f"{kind}_{c}" not in taken]
    free += [f"{kind}_{n}" for n in range(27, 27 + index + 1)]
    return free[index]


# ---------------------------------------------------------------------------
# Drawing
# ---------------------------------------------------------------------------


class _Layout:
    """Footprints and route corridors placed so far; answers whether a new one fits."""

    def __init__(self, scene: SceneSpec, gap: float) -> None:
        self.table = scene.table.polygon()
        self.gap = gap
        self.placed: list[ObjectSpec] = []
        self.corridors: list[tuple[np.ndarray, np.ndarray, float]] = []

    def fits(self, body: ObjectSpec, allowed: str = "") -> bool:
        """On the table, ``gap`` from every body (but the spot ``allowed``) and off every route."""
        grown = _grown(body, self.gap)
        if not all(point_in_polygon(c, self.table) for c in body.footprint()):
            return False
        reach = _radius(body) + self.gap
        for other in self.placed:
            if other.name == allowed or other.name == body.name:
                continue
            if _apart(body.position, other.position, reach + _radius(other)):
                continue
            if footprint_overlap(grown.footprint(), other.footprint()):
                return False
        poly = body.footprint()
        for a, b, r in self.corridors:
            if _point_segment_distance(body.position[:2], a, b) > r + reach:
                continue
            if _segment_polygon_distance(a, b, poly) <= r + self.gap:
                return False
        return True

    def route_fits(self, bot: ObjectSpec, points: list[np.ndarray], parked: ObjectSpec) -> bool:
        """The route's points on the table, its corridor clear of every body placed."""
        radius = _radius(bot)
        if not all(point_in_polygon(p, self.table) for p in points):
            return False
        if not all(point_in_polygon(c, self.table) for c in parked.footprint()):
            return False
        grown = _grown(parked, self.gap).footprint()
        for other in self.placed:
            poly = other.footprint()
            far = radius + self.gap + _radius(other)
            if not _apart(parked.position, other.position, far) and footprint_overlap(grown, poly):
                return False
            for a, b in zip(points[:-1], points[1:], strict=True):
                if _point_segment_distance(other.position[:2], a, b) > far:
                    continue
                if _segment_polygon_distance(a, b, poly) <= radius + self.gap:
                    return False
        return True

    def add_route(self, bot: ObjectSpec, points: list[np.ndarray]) -> None:
        radius = _radius(bot)
        self.corridors += [(a, b, radius) for a, b in zip(points[:-1], points[1:], strict=True)]


def _radius(body: ObjectSpec) -> float:
    """Half the diagonal of a body's footprint (mm): no part of it lies farther out."""
    return 0.5 * float(np.hypot(body.size[0], body.size[1]))


def _apart(p: np.ndarray, q: np.ndarray, distance: float) -> bool:
    return math.hypot(p[0] - q[0], p[1] - q[1]) > distance


def _grown(body: ObjectSpec, gap: float) -> ObjectSpec:
    return dataclasses.replace(body, size=body.size + np.array([2 * gap, 2 * gap, 0.0]))


def _segment_polygon_distance(a: np.ndarray, b: np.ndarray, poly: np.ndarray) -> float:
    """Distance (mm) from the segment a-b to a convex polygon (0 when they meet)."""
    if point_in_polygon(a, poly) or point_in_polygon(b, poly):
        return 0.0
    edges = list(zip(poly, np.roll(poly, -1, axis=0), strict=True))
    if any(_segments_cross(a, b, p, q) for p, q in edges):
        return 0.0
    return min(
        *(_point_segment_distance(p, a, b) for p in poly),
        *(_point_segment_distance(a, p, q) for p, q in edges),
        *(_point_segment_distance(b, p, q) for p, q in edges),
    )


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    t = 0.0 if not ab.any() else float(np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab)))


def _segments_cross(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> bool:
    def turn(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> float:
        return float((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))

    return turn(a, b, c) * turn(a, b, d) < 0 and turn(c, d, a) * turn(c, d, b) < 0


def _uniform(rng: np.random.Generator, r: Range) -> float:
    return float(rng.uniform(r[0], r[1])) if r[1] > r[0] else r[0]


def _point(rng: np.random.Generator, region: Region, spot: ObjectSpec | None) -> np.ndarray:
    """A point drawn in a ring (uniform over its area), a box, or on a spot."""
    if region.kind == "ring":
        r0, r1 = region.a
        r = math.sqrt(_uniform(rng, (r0 * r0, r1 * r1)))
        angle = math.radians(_uniform(rng, region.b))
        return np.array([r * math.cos(angle), r * math.sin(angle)])
    if region.kind == "region":
        return np.array([_uniform(rng, region.a), _uniform(rng, region.b)])
    assert spot is not None
    local = np.array([rng.uniform(-0.5, 0.5) * spot.size[0], rng.uniform(-0.5, 0.5) * spot.size[1]])
    c, s = math.cos(spot.yaw), math.sin(spot.yaw)
    return spot.position[:2] + np.array([c * local[0] - s * local[1], s * local[0] + c * local[1]])


def draw_scene(scene: SceneSpec, seed: int, err: _Errors) -> SceneSpec:
    """The world of ``seed`` (seed 0: ``scene`` itself), deterministic for the seed.

    Raises a ConfigError at the entry that leaves no room for its bodies.
    """
    spec = scene.randomize
    if spec is None or seed == 0:
        return scene
    rng = np.random.default_rng([int(scene.seed) & 0xFFFFFFFF, int(seed) & 0xFFFFFFFF, 11])
    moved = {d.target for d in spec.objects} | {
        o.name for d in spec.objects for o in scene.objects if o.kind == d.target
    }
    layout = _Layout(scene, spec.gap_mm)
    layout.placed = [o for o in scene.objects if o.name not in moved]
    bots = [_draw_park(rng, scene, spec, b, layout, err) for b in scene.duckybots]
    drawn: dict[str, ObjectSpec] = {}
    for draw in spec.objects:
        for i, body in enumerate(_bodies_of(draw, scene, spec, rng)):
            # Past a count's minimum a body with no room left is left out: the world
            # has fewer of the kind, rather than no world at all.
            optional = draw.count is not None and i >= draw.count[0]
            placed = _place(rng, draw, body, scene, layout, err, optional=optional)
            if placed is None:
                break
            drawn[body.name] = placed
    objects = [
        drawn.get(o.name, o) for o in scene.objects if o.name not in moved or o.name in drawn
    ]
    objects += [o for name, o in drawn.items() if name not in {x.name for x in scene.objects}]
    return dataclasses.replace(
        scene,
        objects=objects,
        duckybots=bots,
        light=_light(rng, scene.light, spec.light),
        camera={k: _uniform(rng, r) for k, r in spec.camera.items()},
        slips=_slips(rng, scene.slips, spec.slips),
    )


def _bodies_of(
    draw: ObjectDraw, scene: SceneSpec, spec: RandomizeSpec, rng: np.random.Generator
) -> list[ObjectSpec]:
    if draw.count is None:
        return [o for o in scene.objects if o.name == draw.target or o.kind == draw.target]
    have = [o for o in scene.objects if o.kind == draw.target] + spec.spares.get(draw.target, [])
    n = int(rng.integers(draw.count[0], draw.count[1] + 1))
    return have[:n]


def _place(
    rng: np.random.Generator,
    draw: ObjectDraw,
    body: ObjectSpec,
    scene: SceneSpec,
    layout: _Layout,
    err: _Errors,
    *,
    optional: bool = False,
) -> ObjectSpec | None:
    """``body`` drawn into its region clear of what is placed; None (``optional``) or a
    ConfigError at the entry when it finds no room in :data:`TRIES` draws."""
    spot = next((o for o in scene.objects if o.name == draw.region.spot), None)
    for _ in range(TRIES):
        xy = _point(rng, draw.region, spot)
        yaw = math.radians(_uniform(rng, draw.yaw)) if draw.yaw is not None else body.yaw
        candidate = dataclasses.replace(
            body, position=np.array([xy[0], xy[1], body.position[2]]), yaw=yaw
        )
        if spot is not None and not all(
            point_in_polygon(c, spot.footprint()) for c in candidate.footprint()
        ):
            continue
        if layout.fits(candidate, allowed=draw.region.spot):
            layout.placed.append(candidate)
            return candidate
    if optional:
        return None
    raise err(
        draw.path, f"no room for {body.name} in {TRIES} tries: widen its region or lower count"
    )


def _draw_park(
    rng: np.random.Generator,
    scene: SceneSpec,
    spec: RandomizeSpec,
    bot: DuckybotSpec,
    layout: _Layout,
    err: _Errors,
) -> DuckybotSpec:
    draw = next((p for p in spec.parks if p.name == bot.body.name), None)
    if draw is None:
        points = [np.array(bot.route.start[:2])] + [np.array(leg.target) for leg in bot.route.legs]
        layout.add_route(bot.body, points)
        return bot
    legs = bot.route.legs
    k = next(i for i, leg in enumerate(legs) if leg.kind == "park")
    nominal = np.array(legs[k].target)
    for _ in range(TRIES):
        target = _point(rng, draw.region, None)
        turn = _uniform(rng, draw.heading)
        if draw.region.kind == "ring":
            rotation = math.atan2(target[1], target[0]) - math.atan2(nominal[1], nominal[0])
            move = _rotation(rotation)
        else:
            rotation = 0.0
            shift = target - nominal
            move = lambda p, shift=shift: np.asarray(p, dtype=float) + shift  # noqa: E731
        route = _moved_route(bot.route, move, rotation, k, target, math.radians(turn))
        park = route.legs[k]
        parked = dataclasses.replace(
            bot.body,
            position=np.array([target[0], target[1], bot.body.position[2]]),
            yaw=park.heading if park.heading is not None else bot.body.yaw,
        )
        points = [np.array(route.start[:2])] + [np.array(leg.target) for leg in route.legs]
        start = dataclasses.replace(
            bot.body,
            position=np.array([*route.start[:2], bot.body.position[2]]),
            yaw=route.start[2],
        )
        if not layout.route_fits(bot.body, points, parked) or not layout.fits(start):
            continue
        layout.add_route(bot.body, points)
        layout.placed.append(parked)
        return dataclasses.replace(bot, body=start, route=route)
    raise err(draw.path, f"no room to park {bot.body.name} in {TRIES} tries: widen its region")


def _rotation(angle: float) -> Any:
    c, s = math.cos(angle), math.sin(angle)
    return lambda p: np.array([c * p[0] - s * p[1], s * p[0] + c * p[1]])


def _moved_route(
    route: RouteSpec, move: Any, rotation: float, k: int, target: np.ndarray, turn: float
) -> RouteSpec:
    """The route moved (or turned about the base) with its park leg ``k`` set to ``target``."""
    start = move(route.start[:2])
    legs = []
    for i, leg in enumerate(route.legs):
        point = target if i == k else move(leg.target)
        heading = (
            None if leg.heading is None else leg.heading + rotation + (turn if i == k else 0.0)
        )
        legs.append(
            dataclasses.replace(leg, target=(float(point[0]), float(point[1])), heading=heading)
        )
    return RouteSpec(
        (float(start[0]), float(start[1]), route.start[2] + rotation), legs, route.loop
    )


def _light(rng: np.random.Generator, light: LightSpec, ranges: Mapping[str, Range]) -> LightSpec:
    x, y, z = light.position
    return LightSpec(
        (
            _uniform(rng, ranges.get("x", (x, x))),
            _uniform(rng, ranges.get("y", (y, y))),
            _uniform(rng, ranges.get("z", (z, z))),
        ),
        _uniform(rng, ranges.get("ambient", (light.ambient, light.ambient))),
    )


def _slips(
    rng: np.random.Generator, nominal: SlipSpec | None, spec: Mapping[str, Any] | None
) -> SlipSpec | None:
    if spec is None:
        return nominal
    rate = _uniform(rng, spec["rate"])
    if rate <= 0:
        return None
    return SlipSpec(rate=rate, max_amount=spec["max_amount"], joints=spec["joints"])


__all__ = ["RandomizeSpec", "draw_scene", "parse_randomize"]
