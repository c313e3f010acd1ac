"""The profile sections armtree declares with :mod:`armtree.config.spec`, by name.

``tags``, ``places``, ``table``, ``watchdog``, ``workcell`` and ``calibration`` are
each declared once: the loader checks them with these declarations (every problem
at its FILE:LINE:COL, ``--set`` values included), ``armtree schema`` describes them
and docs/profiles.md's key tables are generated from them
(``python -m armtree.cli.profile_reference --update docs/profiles.md``).
"""

from __future__ import annotations

from dataclasses import replace

from armtree.errors import shown

from .calibration import CALIBRATION
from .profile_sections import DEFAULT_STALL_S, DEFAULT_TICK_S, MAX_STALL_S, MAX_TICK_S
from .spec import Context, Either, Items, MapOf, Number, OneOf, Record, Spec, Text
from .workcell import NEEDED_BY, WORKCELL
from .yamlio import MarkedDict, MarkedList

#: A marker id, as ``tags:`` gives it.
MARKER_ID = Number(integer=True, minimum=0, wanted="a marker id >= 0")
#: A point in the arm's base frame, mm: a place, an obstacle's centre.
XYZ = Items(Number(), length=3, unit="mm", wanted="[x, y, z] in mm", shape="[x, y, z] mm")


def _family_shapes(tag: MarkedDict, path: str, ctx: Context) -> None:
    """``family_ids`` shaped as the role's ``id`` (one id) or ``ids`` (as many ids).

    Which families exist and which ids they carry is the trackers' to say (their
    ``armtree_validate_profile``).
    """
    given = tag.get("family_ids")
    if not isinstance(given, MarkedDict):
        return
    count = len(tag["ids"]) if "ids" in tag else None
    for family, value in given.items():
        where, at = given.value_mark(family), f"{path}.family_ids.{family}"
        if count is None and isinstance(value, list):
            ctx.add(f"{at}: expected one marker id >= 0, got {shown(value)}", where)
        elif count is not None and (not isinstance(value, list) or len(value) != count):
            ctx.add(
                f"{at}: expected a list of {count} marker ids, one for each of {path}.ids, "
                f"got {shown(value)}",
                where,
            )


def _one_role_per_id(tags: MarkedDict, path: str, ctx: Context) -> None:
    """No marker id may belong to two roles."""
    owner: dict[int, str] = {}
    for role, tag in tags.items():
        if not isinstance(tag, MarkedDict):
            continue
        ids = tag.get("ids") if "id" not in tag else MarkedList([tag["id"]])
        if not isinstance(ids, list):
            continue
        for i, marker in enumerate(ids):
            if not MARKER_ID.accepts(marker, ctx):
                continue
            mark = tag.value_mark("id") if "id" in tag else tag["ids"].item_mark(i)
            if marker in owner:
                ctx.add(
                    f"{path}.{role}: marker id {marker} is already used by tag {owner[marker]!r}",
                    mark,
                )
            else:
                owner[marker] = str(role)


#: ``tags:``: each role's marker ids, their side, their ids in other marker families.
TAG = Record(
    {
        "id": replace(MARKER_ID, doc="the role's marker id"),
        "ids": Items(
            MARKER_ID,
            "the role's marker ids: several markers of one role",
            min_items=1,
            each=True,
            wanted="a non-empty list of marker ids",
            shape="[int >= 0, ...]",
        ),
        "size_mm": Number(
            "the side of the printed black square, needed for a marker's pose",
            "mm",
            above=0.0,
            wanted="a number > 0 (mm)",
        ),
        "family_ids": MapOf(
            Either((MARKER_ID, Items(MARKER_ID, min_items=1, each=True, shape="[int >= 0, ...]"))),
            doc="the same markers' ids in another marker family (hamming, an ArUco "
            "dictionary such as 4x4_50 or apriltag_36h11), shaped as id or ids",
            wanted="a mapping of marker family: id, e.g. {hamming: 69937}",
            key_word="family",
            min_entries=1,
        ),
    },
    required=("size_mm",),
    one_of=("id", "ids"),
    wanted="{id: N, size_mm: S}",
    rule=_family_shapes,
)
TAGS = MapOf(
    TAG,
    doc="marker ids, their roles and sizes",
    wanted="a mapping of role: {id, size_mm}",
    key_word="role",
    rule=_one_role_per_id,
)
PLACES = MapOf(
    XYZ,
    doc="named points [x, y, z] (mm) in the arm's base frame",
    wanted="a mapping of name: [x, y, z] (mm)",
)
TABLE = Either(
    (
        Number(unit="mm", wanted="a number (mm)"),
        Record(
            {"z": Number("the table top's height", "mm", wanted="a number (mm)")},
            required=("z",),
        ),
    ),
    "the table top: {z: MM}, its height in the arm's base frame",
    wanted="{z: MM} (the table top's height, mm)",
)
WATCHDOG = Record(
    {
        "tick_s": Number(
            "the longest one tick may take on the wall clock before the run ends with exit 3",
            "s",
            DEFAULT_TICK_S,
            above=0.0,
            maximum=MAX_TICK_S,
            wanted=f"a number of seconds > 0 and <= {MAX_TICK_S:g}",
        ),
        "stall_s": Number(
            "how long a run may make no progress (run time) before it is reported as a stall",
            "s",
            DEFAULT_STALL_S,
            above=0.0,
            maximum=MAX_STALL_S,
            wanted=f"a number of seconds > 0 and <= {MAX_STALL_S:g}",
        ),
    },
    doc="the longest one tick may take on the wall clock (tick_s); how long a run may make "
    "no progress before it is reported as a stall (stall_s, run time)",
    wanted="a mapping {tick_s: SECONDS, stall_s: SECONDS} (the longest one tick may take, "
    "how long a run may make no progress)",
)


def _positive_size(box: MarkedDict, path: str, ctx: Context) -> None:
    if min(box["size"]) <= 0:
        ctx.add(f"{path}.size: sizes must be > 0 mm", box.value_mark("size"))


_NAME = Text("its name in collision messages")
_RPY = replace(
    XYZ,
    doc="roll, pitch, yaw",
    unit="deg",
    wanted="[roll, pitch, yaw] in degrees",
    shape="[roll, pitch, yaw] deg",
)
_LENGTH = Number(unit="mm", above=0.0, wanted="a number > 0 (mm)")
#: ``obstacles:``: shapes the planners keep the arm out of (mm, degrees).
OBSTACLES = Items(
    OneOf(
        {
            "box": Record(
                {
                    "center": replace(XYZ, doc="its centre"),
                    "size": replace(XYZ, doc="its edges along its own x, y, z"),
                    "rpy": replace(_RPY, doc="its orientation (default level)"),
                    "name": _NAME,
                },
                required=("center", "size"),
                rule=_positive_size,
            ),
            "cylinder": Record(
                {
                    "center": replace(XYZ, doc="its centre"),
                    "radius": replace(_LENGTH, doc="its radius"),
                    "height": replace(_LENGTH, doc="its height"),
                    "rpy": replace(_RPY, doc="its orientation (default: axis vertical)"),
                    "name": _NAME,
                },
                required=("center", "radius", "height"),
            ),
            "sphere": Record(
                {
                    "center": replace(XYZ, doc="its centre"),
                    "radius": replace(_LENGTH, doc="its radius"),
                    "name": _NAME,
                },
                required=("center", "radius"),
            ),
            "mesh": Record(
                {
                    "file": Text("STL or OBJ file, relative to the profile"),
                    "position": replace(XYZ, doc="where its origin goes"),
                    "rpy": replace(_RPY, doc="its orientation"),
                    "scale": Number("factor on its coordinates", default=1.0, above=0.0),
                    "name": _NAME,
                },
                required=("file",),
            ),
        },
        wanted="one shape (box, cylinder, sphere, mesh), e.g. "
        "{box: {center: [x, y, z], size: [dx, dy, dz]}}",
    ),
    "shapes the planners keep the arm out of (mm)",
    each=True,
    wanted="a list of shapes",
)

#: Section name -> its declaration.
SECTION_SPECS: dict[str, Spec] = {
    "tags": TAGS,
    "places": PLACES,
    "table": TABLE,
    "obstacles": OBSTACLES,
    "workcell": WORKCELL,
    "calibration": CALIBRATION,
    "watchdog": WATCHDOG,
}
#: The key tables docs/profiles.md shows: section -> (its keys, who needs a key without
#: a default).
KEY_TABLES: dict[str, tuple[Record, dict[str, str]]] = {
    "tags": (TAG, {}),
    "workcell": (WORKCELL, NEEDED_BY),
    "watchdog": (WATCHDOG, {}),
}


def check_sections(data: MarkedDict, ctx: Context) -> set[str]:
    """Check every declared section ``data`` has; return those with errors."""
    invalid = set()
    for name, spec in SECTION_SPECS.items():
        if data.get(name) is not None and not spec.check(
            data[name], name, data.value_mark(name), ctx
        ):
            invalid.add(name)
    return invalid
