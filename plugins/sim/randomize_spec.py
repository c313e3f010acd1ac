"""The ``world.randomize:`` section declared (:mod:`armtree.config.spec`), as ``world:`` is.

:data:`RANDOMIZE` declares the keys of what ``--seed N`` draws (:mod:`.randomize`
says what each means): the shape of every entry, each range's order and bounds, and
that a draw names exactly one region. From it come the load-time checks at
FILE:LINE:COL, the JSON Schema and the key table of docs/profiles.md. What an entry
may name (a body, a kind, a spot, a Duckybot with a park leg) depends on the
objects, so :func:`.randomize.parse_randomize` checks that once this has passed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from armtree.config.spec import Context, Items, MapOf, Number, Record, Spec, Text, finite_number
from armtree.config.yamlio import MarkedDict
from armtree.errors import Mark, shown


@dataclass(frozen=True)
class Range(Spec):
    """``[MIN, MAX]`` or one number (a fixed value), parsed as ``(MIN, MAX)`` floats.

    ``low`` is the least MIN allowed; ``whole``: both ends whole numbers (a count)."""

    doc: str = ""
    default: Any = None
    low: float | None = None
    whole: bool = False
    unit: str = ""

    def want(self) -> str:
        return "a range [MIN, MAX] or a number"

    def brief(self) -> str:
        return f"[MIN, MAX] {self.unit}" if self.unit else "[MIN, MAX]"

    def _pair(self, value: Any) -> tuple[float, float] | None:
        if finite_number(value):
            return float(value), float(value)
        if isinstance(value, (list, tuple)) and len(value) == 2 and all(map(finite_number, value)):
            return float(value[0]), float(value[1])
        return None

    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        pair = self._pair(value)
        if pair is None:
            ctx.add(f"{path}: expected {self.want()}, got {shown(value)}", at)
        elif pair[0] > pair[1]:
            ctx.add(
                f"{path}: the range {shown(value)} has MIN > MAX; write [{pair[1]:g}, {pair[0]:g}]",
                at,
            )
        elif self.low is not None and pair[0] < self.low:
            ctx.add(f"{path}: must be at least {self.low:g}, got {pair[0]:g}", at)
        elif self.whole and not all(v == int(v) for v in pair):
            ctx.add(f"{path}: expected whole numbers, got {shown(value)}", at)
        else:
            return True
        return False

    def schema(self) -> dict[str, Any]:
        number: dict[str, Any] = {"type": "integer" if self.whole else "number"}
        if self.low is not None:
            number["minimum"] = self.low
        pair = {"type": "array", "items": number, "minItems": 2, "maxItems": 2}
        return self._described({"anyOf": [number, pair]}, self.unit)

    def parse(self, value: Any) -> Any:
        return None if value is None else self._pair(value)


def _one_region(choices: tuple[str, ...]) -> Any:
    """A rule: exactly one of ``choices`` in the entry."""

    def rule(entry: MarkedDict, path: str, ctx: Context) -> None:
        if sum(key in entry for key in choices) != 1:
            ctx.add(f"{path}: give exactly one region: {' or '.join(choices)}", entry.mark)

    return rule


def _range_within(key: str, top: float, message: str, closed: bool) -> Any:
    """A rule: the range at ``key`` ends at ``top`` at most (``closed``) or below it."""

    def rule(entry: MarkedDict, path: str, ctx: Context) -> None:
        pair = Range().parse(entry.get(key))
        if pair is not None and (pair[1] > top if closed else pair[1] >= top):
            ctx.add(f"{path}.{key}: {message}", entry.value_mark(key))

    return rule


RING = Record(
    {
        "r": Range("distance from the arm's base", low=0.0, unit="mm"),
        "angle": Range("bearing about the arm's base", default=(-180.0, 180.0), unit="degrees"),
    },
    required=("r",),
    doc="a ring about the arm's base",
    key_paths=True,
    absent="one region: on, ring or region",
)
BOX = Record(
    {"x": Range("x", unit="mm"), "y": Range("y", unit="mm")},
    required=("x", "y"),
    doc="an axis-aligned box on the table",
    key_paths=True,
    absent="one region: on, ring or region",
)


@dataclass(frozen=True)
class _DrawRecord(Record):
    """A draw's entry; a bare ``on`` key, which YAML 1.1 reads as ``true``, is ``on``."""

    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        if isinstance(value, MarkedDict) and True in value:
            value["on"] = value.pop(True)
            for marks in (value.key_marks, value.value_marks):
                if True in marks:
                    marks["on"] = marks.pop(True)
        return super().check(value, path, at, ctx)

    def schema(self) -> dict[str, Any]:
        # a YAML 1.1 reader (PyYAML) hands a validator the key true, which no property
        # name matches; the loader's own check still refuses unknown keys
        return super().schema() | {"additionalProperties": True}

    def parse(self, value: Any) -> Any:
        if isinstance(value, dict) and True in value:
            value = {("on" if k is True else k): v for k, v in value.items()}
        return super().parse(value)


_REGIONS = ("on", "ring", "region")
OBJECT_DRAW = _DrawRecord(
    {
        "on": Text("a spot the body's footprint lies wholly on"),
        "ring": RING,
        "region": BOX,
        "yaw": Range("heading", unit="degrees"),
        "count": Range("how many bodies of the kind (kinds only)", low=0.0, whole=True),
    },
    doc="where a body (or every body of a kind) is drawn: one region, a heading, a count",
    rule=_one_region(_REGIONS),
    key_paths=True,
)
PARK = Record(
    {
        "ring": RING,
        "region": BOX,
        "heading": Range("turn of the whole route", default=(0.0, 0.0), unit="degrees"),
    },
    doc="where the Duckybot parks: one region, and how far its route turns",
    rule=_one_region(_REGIONS[1:]),
    key_paths=True,
)
SLIPS = Record(
    {
        "rate_per_s": Range("missed steps a second", low=0.0),
        "max_amount": Number("largest missed step", default=1.0, above=0.0),
        "joints": Items(
            Number(integer=True, minimum=0), doc="joints that miss steps (all if none)"
        ),
    },
    required=("rate_per_s",),
    doc="the rate of missed steps",
    key_paths=True,
)


def _drawn(doc: str, rule: Any = None, **fields: Spec) -> Record:
    """A part of the world whose values are drawn; left out, they are not."""
    return Record(fields, doc=doc, rule=rule, key_paths=True, absent="not drawn")


RANDOMIZE = Record(
    {
        "objects": MapOf(OBJECT_DRAW, doc="draws by body or kind name", key_word="body_or_kind"),
        "duckybots": MapOf(
            Record({"park": PARK}, required=("park",), key_paths=True),
            doc="parking draws by Duckybot name",
        ),
        "light": _drawn(
            "the lamp's position and the ambient light",
            x=Range("lamp x", unit="mm"),
            y=Range("lamp y", unit="mm"),
            z=Range("lamp z", unit="mm"),
            ambient=Range("ambient share of the light", low=0.0),
            rule=_range_within("ambient", 1.0, "ambient light is between 0 and 1", closed=True),
        ),
        "camera": _drawn(
            "the camera's noise, blur and frame drops",
            noise=Range("sensor noise sd", low=0.0, unit="grey levels"),
            blur=Range("defocus blur sd", low=0.0, unit="px"),
            drop_rate=Range("share of frames dropped", low=0.0),
            rule=_range_within("drop_rate", 1.0, "a drop rate is below 1", closed=False),
        ),
        "faults": _drawn("drawn faults", missed_steps=SLIPS),
        "gap_mm": Number("least distance between drawn bodies", default=5.0, unit="mm"),
    },
    doc="what --seed N > 0 draws: where objects lie, the Duckybot's parking, the light, "
    "the camera's noise, missed steps (docs/sim.md)",
    wanted="a mapping (objects, duckybots, light, camera, faults, gap_mm)",
    key_paths=True,
    absent="none: every seed runs the nominal world",
)

__all__ = ["BOX", "OBJECT_DRAW", "PARK", "RANDOMIZE", "RING", "Range"]
