"""The ``world:`` section of a hardware profile, declared once (:mod:`armtree.config.spec`).

:data:`WORLD` declares every key of the simulated world: the table, the objects
and their markers, the Duckybots and their routes, faults, physics, the light,
the tool's marker, how the rig is really built (``as_built``) and the simulated
measuring device (``reference``). From it come the load-time checks (each problem
at its FILE:LINE:COL, ``--set`` values included), the JSON Schema ``armtree
schema`` writes, the values ``scene.parse_scene`` builds the scene from, and the
key tables of docs/profiles.md.

A rule that spans the keys of one entry (a cylinder's size, a bin's wall, which
keys missed steps take) is a :class:`Record`'s ``rule`` here. What needs the rest
of the profile (``tags:``, ``tracker:``, ``obstacles:``) or every body at once
(bodies off the table or inside each other, marker ids, routes off the table) is
checked by ``scene.py`` once this declaration has passed; what ``randomize:``
(declared in ``randomize_spec.py``) may name is checked by ``randomize.py``.

Lengths are millimetres and angles degrees in the robot's base frame (z up);
colours are BGR, 0 to 255.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

from armtree.config.spec import (
    Anything,
    Boolean,
    Choice,
    Context,
    Either,
    Items,
    MapOf,
    Number,
    Record,
    Text,
)
from armtree.config.yamlio import MarkedDict
from armtree.errors import shown

from .as_built import DEFAULT_NOISE_MM
from .duckybot import DuckybotParams, Leg
from .randomize_spec import RANDOMIZE
from .scene_spec import LightSpec, PhysicsSpec, SlipSpec, TableSpec

#: Object kinds, their default size (mm), colour (BGR) and tag role.
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
#: A bin's wall thickness (mm) unless its entry gives ``wall_mm``.
BIN_WALL_MM = 3.0
#: The largest seed: numpy's generators take a 63-bit one.
MAX_SEED = 2**63 - 1


def body_size(kind: str, shape: str | None, size: Sequence[float] | None) -> list[float]:
    """A body's (x, y, z) extents (mm): ``size`` as written, a cylinder's
    ``[diameter, height]`` made three, or its kind's size when it gives none."""
    given = list(KINDS[kind]["size"] if size is None else size)
    if shape == "cylinder" and len(given) == 2:
        return [given[0], given[0], given[1]]
    return given


def _body_rule(kind: str | None) -> Callable[[MarkedDict, str, Context], None]:
    """The checks of a body's size and wall, which depend on its kind and shape
    (``kind`` for an entry that has no ``kind:`` key, a Duckybot's)."""

    def rule(entry: MarkedDict, path: str, ctx: Context) -> None:
        body = kind or entry["kind"]
        shape = entry.get("shape")
        where = entry.value_mark("size")
        written = entry.get("size")
        if written is not None and len(written) == 2 and shape != "cylinder":
            ctx.add(
                f"{path}.size: expected [x, y, z] in mm ([diameter, height] is a cylinder's "
                f"size: add shape: cylinder), got {shown(written)}",
                where,
            )
            return
        size = body_size(body, shape, written)
        if min(size[:2]) <= 0 or size[2] < 0 or (size[2] == 0 and body != "spot"):
            ctx.add(
                f"{path}.size: sizes must be positive (only a spot's height may be 0), "
                f"got {shown(written)}",
                where,
            )
            return
        wall = entry.get("wall_mm")
        wall = BIN_WALL_MM if wall is None else wall
        if body == "bin" and not 0 < wall < min(size[:2]) / 2:
            ctx.add(
                f"{path}.wall_mm: wall {wall:g} mm does not fit a {size[0]:g} x {size[1]:g} mm "
                "bin: give a wall > 0 and less than half the bin's width",
                entry.value_mark("wall_mm"),
            )

    return rule


def _xy(doc: str = "", default: Any = None) -> Items:
    """``[x, y]`` on the table (mm)."""
    return Items(Number(), doc, default, length=2, wanted="[x, y] in mm", shape="[x, y] mm")


def _span(doc: str, default: tuple[float, float]) -> Items:
    """``[min, max]`` along one axis (mm)."""
    return Items(Number(), doc, default, length=2, wanted="[min, max] in mm", shape="[min, max] mm")


def _xyz(doc: str = "", default: Any = None) -> Items:
    """``[x, y, z]`` (mm)."""
    return Items(Number(), doc, default, length=3, wanted="[x, y, z] in mm", shape="[x, y, z] mm")


def _positive(doc: str, unit: str = "", default: Any = None) -> Number:
    """A number > 0, in ``unit``."""
    return Number(
        doc, unit, default, above=0.0, wanted="a number > 0" + (f" ({unit})" if unit else "")
    )


_COLOR = Items(
    Number(minimum=0.0, maximum=255.0),
    "its colour, [blue, green, red] from 0 to 255 (default: its kind's)",
    length=3,
    wanted="[blue, green, red], each from 0 to 255",
    shape="[b, g, r]",
)
_SIZE = Items(
    Number(minimum=0.0),
    "its extents [x, y, z] (mm; a cylinder's x and y are its diameter, or write "
    "[diameter, height]; default: its kind's)",
    min_items=2,
    max_items=3,
    wanted="[x, y, z] in mm, all positive ([diameter, height] for a cylinder; "
    "a spot's height may be 0)",
    shape="[x, y, z] mm",
)
#: A printed marker: its id as ``tags:`` writes it, its side and the family it is printed in.
MARKER = Record(
    {
        "id": Number(
            "its id as tags: writes it (default: its tag role's next id)",
            integer=True,
            minimum=0,
            wanted="a marker id (integer >= 0)",
        ),
        "size_mm": _positive("its side (default: its tag role's size_mm in tags:, else 25)", "mm"),
        "family": Text(
            "the family it is printed in: hamming, aruco (with dictionary), apriltag, or an "
            "ArUco dictionary's name (default: the one the profile's tracker reads)"
        ),
        "dictionary": Text("the ArUco dictionary (4x4_50, apriltag_36h11, ...)"),
    },
    doc="the marker printed on its top face",
    wanted="a mapping {id, size_mm, family, dictionary}",
    key_paths=True,
)
_MARKER_OR_NONE = Either(
    (Choice((False,)), MARKER),
    "the marker on its top face, or false for none (default: its tag role's marker, when "
    "tags: has the role)",
    wanted="false or a mapping {id, size_mm, family, dictionary}",
)
#: One body of ``world.objects``.
OBJECT = Record(
    {
        "kind": Choice(
            tuple(k for k in KINDS if k != "duckybot"),
            "what it is, which sets its default size, colour and tag role: ducky, trash, "
            "block, obstacle, bin or spot",
            advice={"duckybot": "duckybots go under world.duckybots"},
        ),
        "shape": Choice(SHAPES, "box, or cylinder (upright)", "box"),
        "size": _SIZE,
        "at": Items(
            Number(),
            "the position [x, y] (mm) on the table, or [x, y, z]: the centre of its bottom face",
            min_items=2,
            max_items=3,
            wanted="[x, y] or [x, y, z] in mm",
            shape="[x, y] mm",
        ),
        "yaw": Number("its turn about the vertical", "deg", 0.0),
        "color": _COLOR,
        "marker": _MARKER_OR_NONE,
        "wall_mm": Number(
            f"a bin's wall thickness (mm; default {BIN_WALL_MM:g} for a bin)",
            "mm",
            minimum=0.0,
            wanted="a number >= 0 (mm)",
        ),
        "mass_g": _positive("its mass (not simulated yet)", "g"),
    },
    required=("kind", "at"),
    doc="a body on the table",
    wanted="a mapping {kind: ..., at: [x, y], ...}",
    rule=_body_rule(None),
    key_paths=True,
)


def _missed_steps_rule(entry: MarkedDict, path: str, ctx: Context) -> None:
    """Missed steps once take ``joint`` and ``amount``; under load ``rate_per_s``,
    ``max_amount`` and ``joints``."""
    under_load = entry.get("rate_per_s") is not None
    takes = ("rate_per_s", "max_amount", "joints") if under_load else ("joint", "amount")
    for key, value in entry.items():
        if value is not None and key not in takes:
            mode = "under load (with rate_per_s)" if under_load else "once (without rate_per_s)"
            ctx.add(
                f"{path}.{key}: missed steps {mode} take {', '.join(takes)}, not {key}",
                entry.key_mark(key),
            )
    if not under_load and entry.get("amount") is None:
        ctx.add(
            f"{path}: needs amount: how far the joint slips (degrees, or mm on a linear axis)",
            entry.mark,
        )


#: Options of each one-shot fault (``PtyEmulator.inject``) and the range of each, inclusive.
_FAULT_OPTIONS: dict[str, dict[str, tuple[float, float]]] = {
    "corrupt": {"rate": (0.0, 1.0), "count": (0, 1e9)},
    "drop": {"rate": (0.0, 1.0), "count": (0, 1e9)},
    "cut": {"silent": (0, 1)},
    # servo buses (the arm's factory lists the faults its emulator takes: ``faults``)
    "lost_replies": {"rate": (0.0, 1.0), "count": (0, 1e9)},
    "latency": {"seconds": (0.0, 10.0)},
    "overload": {"joint": (0, 63), "id": (0, 252), "after_s": (0.0, 1e6)},
    "overheat": {"joint": (0, 63), "id": (0, 252), "after_s": (0.0, 1e6)},
}
_FAULT_DOCS = {
    "corrupt": "garble replies: a share of them (rate) or a number (count)",
    "drop": "leave replies out: a share of them (rate) or a number (count)",
    "cut": "cut the link once (silent: 1 without a word)",
    "lost_replies": "a servo bus loses replies: a share of them (rate) or a number (count)",
    "latency": "a servo bus answers late (seconds)",
    "overload": "a servo (joint or bus id) reports overload after after_s seconds",
    "overheat": "a servo (joint or bus id) reports overheating after after_s seconds",
}
#: The faults every arm emulator takes (an arm factory's ``faults`` may list more).
BASE_FAULTS = ("missed_steps", "corrupt", "drop", "cut")


def _option(low: float, high: float) -> Number:
    return Number(minimum=low, maximum=high, wanted=f"a number from {low:g} to {high:g}")


def _one_shot(name: str) -> Either:
    """A one-shot fault: true (its defaults), false (none) or a mapping of its options."""
    options = _FAULT_OPTIONS[name]
    record = Record(
        {key: _option(*bounds) for key, bounds in options.items()},
        wanted="{" + ", ".join(options) + "}",
        key_paths=True,
    )
    return Either((Boolean(), record), _FAULT_DOCS[name], wanted=f"true, false or {record.wanted}")


_SLIPS = SlipSpec(rate=0.0)
#: ``world.faults.missed_steps``: a joint slips once, or at random under load.
MISSED_STEPS = Record(
    {
        "joint": replace(_option(0, 63), doc="the joint that slips once (0 is the first)"),
        "amount": Number(
            "how far the joint slips once (degrees, or mm on a linear axis)",
            minimum=-360.0,
            maximum=360.0,
            wanted="a number from -360 to 360",
        ),
        "rate_per_s": _positive(
            "slips per second while the arm moves or holds something (missed steps under load)",
            "1/s",
        ),
        "max_amount": _positive(
            "the largest slip under load, either way (degrees, or mm on a linear axis)",
            default=_SLIPS.max_amount,
        ),
        "joints": Items(
            Number(integer=True, minimum=0),
            "the joints that may slip under load (default: all)",
            _SLIPS.joints,
            wanted="a list of joint indices (integers >= 0)",
            shape="[int, ...]",
        ),
    },
    doc="missed steps: {joint, amount} once at the start, or {rate_per_s, max_amount, "
    "joints} at random under load",
    wanted="{joint, amount} or {rate_per_s, max_amount, joints}",
    rule=_missed_steps_rule,
    key_paths=True,
)
FAULTS = Record(
    {
        "missed_steps": Either(
            (Choice((False,)), MISSED_STEPS),
            MISSED_STEPS.doc,
            wanted=f"false or {MISSED_STEPS.wanted}",
        ),
        **{name: _one_shot(name) for name in _FAULT_OPTIONS},
    },
    doc="faults the arm's emulator injects (the arm type's emulator must take them)",
    wanted="a mapping of fault: options (" + ", ".join(("missed_steps", *_FAULT_OPTIONS)) + ")",
    key_paths=True,
)


def _ordered_table(table: MarkedDict, path: str, ctx: Context) -> None:
    """The table's ranges run from min to max."""
    spans = [table.get(axis) for axis in ("x", "y")]
    if any(span is not None and span[0] >= span[1] for span in spans):
        ctx.add(f"{path}: x and y must be [min, max] with min < max", table.mark)


_TABLE = TableSpec()
#: ``world.table``: the table top.
TABLE = Record(
    {
        "x": _span("its x range (mm)", _TABLE.x),
        "y": _span("its y range (mm)", _TABLE.y),
        "height": Number("the height of its surface", "mm", _TABLE.height),
        "texture": Choice(("wood", "plain", "checker"), "how its top looks", _TABLE.texture),
    },
    doc="the table top",
    wanted="a mapping {x: [min, max], y: [min, max], height, texture}",
    build=TableSpec,
    rule=_ordered_table,
    key_paths=True,
)
_PHYSICS = PhysicsSpec()
#: ``world.physics``: tool and collision physics.
PHYSICS = Record(
    {
        "pick_tolerance_mm": _positive(
            "how far from a top face the suction cup still picks", "mm", _PHYSICS.pick_tolerance_mm
        ),
        "collision_tolerance_mm": Number(
            "how deep the arm may touch a body before it is a collision",
            "mm",
            _PHYSICS.collision_tolerance_mm,
        ),
        "halt_on_collision": Boolean(
            "a collision halts the arm and fails the run", _PHYSICS.halt_on_collision
        ),
        "gripper_mm_per_unit": _positive(
            "jaw opening per unit of the gripper command", "mm", _PHYSICS.gripper_mm_per_unit
        ),
    },
    doc="tool and collision physics",
    wanted="a mapping {pick_tolerance_mm, collision_tolerance_mm, halt_on_collision, "
    "gripper_mm_per_unit}",
    build=PhysicsSpec,
    key_paths=True,
)
_LIGHT = LightSpec()
#: ``world.light``: a lamp above the table.
LIGHT = Record(
    {
        "position": _xyz("where the lamp is (mm)", _LIGHT.position),
        "ambient": Number(
            "the share of light that comes from everywhere",
            default=_LIGHT.ambient,
            minimum=0.0,
            maximum=1.0,
            wanted="a number from 0 to 1",
        ),
    },
    doc="a point lamp above the table",
    wanted="a mapping {position: [x, y, z], ambient: 0..1}",
    build=LightSpec,
    key_paths=True,
)
#: ``world.tool_marker``: a marker on the tool, for eye-to-hand servoing and calibration.
TOOL_MARKER = replace(
    MARKER,
    fields={
        **MARKER.fields,
        "offset": _xyz("its centre in the tool frame (mm)", (0.0, 0.0, 20.0)),
    },
    doc="a marker on the tool (eye-to-hand servoing and calibration)",
    wanted="a mapping {id, size_mm, family, dictionary, offset}",
)
_LEG = Record(
    {
        "drive_to": _xy("drive to [x, y] (mm)"),
        "park": Items(
            Number(),
            "drive to [x, y] (mm), turn to heading (deg) when given, and wait",
            min_items=2,
            max_items=3,
            wanted="[x, y] or [x, y, heading] (mm, degrees)",
            shape="[x, y, heading]",
        ),
        "until": Choice(
            ("loaded", "time"),
            "a park ends wait_s after it is loaded, or after wait_s (time)",
            Leg.until,
        ),
        "wait_s": Number("how long a park waits", "s", Leg.wait, minimum=0.0),
        "timeout_s": _positive("the longest a park waits to be loaded (default: no end)", "s"),
    },
    doc="one leg of a route",
    wanted="{drive_to: [x, y]} or {park: [x, y, heading], until, wait_s, timeout_s}",
    one_of=("drive_to", "park"),
    key_paths=True,
)
#: One leg of a route: a point to drive to, or a mapping.
LEG = Either(
    (_xy(), _LEG),
    wanted="[x, y], {drive_to: [x, y]} or {park: [x, y, heading_deg], ...}",
)
_BOT = DuckybotParams()
#: ``world.duckybots.NAME.gains``: the Duckybot's path-following controller.
GAINS = Record(
    {
        "kp": _positive("the gain on the distance off the path", default=_BOT.kp),
        "ktheta": _positive("the gain on the heading error", default=_BOT.ktheta),
    },
    doc="its path-following controller's gains",
    wanted="a mapping {kp, ktheta}",
    key_paths=True,
)
#: One Duckybot of ``world.duckybots``.
DUCKYBOT = Record(
    {
        "size": replace(_SIZE, doc="its extents [x, y, z] (mm)"),
        "color": replace(_COLOR, doc="its colour, [blue, green, red] from 0 to 255"),
        "marker": _MARKER_OR_NONE,
        "start": Items(
            Number(),
            "where it starts: [x, y] (mm) or [x, y, heading] (mm, degrees)",
            (0.0, 0.0, 0.0),
            min_items=2,
            max_items=3,
            wanted="[x, y] or [x, y, heading] (mm, degrees)",
            shape="[x, y, heading]",
        ),
        "route": Items(
            LEG,
            "its legs, in order: [x, y], {drive_to: [x, y]} or {park: [x, y, heading], ...}",
            (),
            each=True,
            wanted="a list of legs",
            shape="[leg, ...]",
        ),
        "loop": Boolean("drive the route again and again", False),
        "speed_mm_s": _positive("its speed along straight legs", "mm/s", _BOT.speed),
        "turn_deg_s": _positive(
            "how fast it turns on the spot", "deg/s", math.degrees(_BOT.turn_rate)
        ),
        "gains": GAINS,
        "noise": Number(
            "its actuators' relative noise (standard deviation)",
            default=_BOT.noise,
            minimum=0.0,
            wanted="a number >= 0",
        ),
        "max_speed_mm_s": _positive("its wheels' top speed", "mm/s", _BOT.max_speed),
    },
    doc="a Duckybot and its route",
    wanted="a mapping {start, route, ...}",
    rule=_body_rule("duckybot"),
    key_paths=True,
)


def _not_type_or_port(arm: MarkedDict, path: str, ctx: Context) -> None:
    """``as_built.arm`` changes the arm's own keys, never which arm it is."""
    for key in ("type", "port"):
        if key in arm:
            ctx.add(
                f"{path}.{key}: as_built.arm takes the arm type's own keys, not type or port",
                arm.key_mark(key),
            )


#: ``world.as_built.camera``: where the camera really is.
AS_BUILT_CAMERA = Record(
    {
        "offset_mm": Items(
            Number(bound=200.0),
            "where it really stands from the profile's position (mm; base frame eye-to-hand, "
            "tool frame eye-in-hand)",
            (0.0, 0.0, 0.0),
            length=3,
            wanted="three numbers within +/-200 (mm)",
            shape="[x, y, z] mm",
        ),
        "rotation_deg": Items(
            Number(bound=30.0),
            "how it is really turned: roll, pitch, yaw about its own axes (deg)",
            (0.0, 0.0, 0.0),
            length=3,
            wanted="three numbers within +/-30 (degrees)",
            shape="[roll, pitch, yaw] deg",
        ),
    },
    doc="the camera's pose error",
    wanted="{offset_mm: [x, y, z], rotation_deg: [r, p, y]}",
    key_paths=True,
)
#: ``world.as_built``: how the simulated rig really is.
AS_BUILT = Record(
    {
        "camera": AS_BUILT_CAMERA,
        "arm": MapOf(
            Anything(),
            doc="keys of the profile's arm type the real arm has instead (not type or port)",
            wanted="a mapping of the arm type's own keys (not type or port)",
            key_word="key",
            rule=_not_type_or_port,
        ),
    },
    doc="how the simulated rig really is, where the profile says what it should be",
    wanted="a mapping with camera and/or arm",
    key_paths=True,
)
#: ``world.reference``: the simulated measuring device.
REFERENCE = Record(
    {
        "noise_mm": Number(
            "its reading error, standard deviation per axis",
            "mm",
            DEFAULT_NOISE_MM,
            minimum=0.0,
            maximum=50.0,
            wanted="a reading error of 0 to 50 mm",
        )
    },
    doc="the simulated measuring device (rig.reference)",
    wanted="{noise_mm: MM}",
    key_paths=True,
)
#: The ``world:`` section.
WORLD = Record(
    {
        "seed": Number(
            "the nominal world's seed: Duckybot wheel noise, sensor noise, drops",
            default=0,
            minimum=0,
            maximum=MAX_SEED,
            integer=True,
            wanted="an integer from 0 to 2**63 - 1",
        ),
        "table": TABLE,
        "objects": MapOf(
            OBJECT,
            doc="the bodies on the table, by name",
            wanted="a mapping of name: {kind: ..., at: [x, y]}",
        ),
        "duckybots": MapOf(
            DUCKYBOT,
            doc="the Duckybots, by name",
            wanted="a mapping of name: {route: [...], ...}",
        ),
        "faults": FAULTS,
        "physics": PHYSICS,
        "light": LIGHT,
        "tool_marker": TOOL_MARKER,
        "randomize": RANDOMIZE,
        "as_built": AS_BUILT,
        "reference": REFERENCE,
    },
    doc="the simulated world: table, objects, Duckybot, faults (simulation only; docs/sim.md)",
    wanted="a mapping (table, objects, duckybots, ...)",
    key_paths=True,
)

__all__ = [
    "AS_BUILT",
    "BASE_FAULTS",
    "DUCKYBOT",
    "FAULTS",
    "GAINS",
    "KINDS",
    "LEG",
    "LIGHT",
    "MARKER",
    "MISSED_STEPS",
    "OBJECT",
    "PHYSICS",
    "REFERENCE",
    "SHAPES",
    "TABLE",
    "TOOL_MARKER",
    "WORLD",
    "body_size",
]
