"""The ``workcell:`` profile section: what skills need to know about a rig's task geometry.

Trees carry task choices (which tag, clean up or not); the numbers that belong to
one rig live here, so one tree runs on every rig:

```yaml
workcell:
  table_z_mm: -35          # the table top the camera looks at (base frame, mm)
  clearance_z_mm: 20       # lowest tool height while travelling or looking: clears every top
  look_height_mm: 100      # camera height above the table while surveying
  survey:                  # where the camera looks for tags: one of ring / rectangle / viewpoints
    ring: {radius_mm: 185, range_deg: [-100, 100], step_deg: 5}
  search_radius_mm: 80     # how far from a place a tag may be and still be the one meant
  grasp_offset_mm: 0       # tool height above an object's marker when gripping
  release_offset_mm: 35    # tool height above the target's marker when letting go
  sort: {trash: garbage_bin}   # the place each tag role belongs (sort.yaml)
  marker_heights_mm: {ducky: 30, trash: 20, duckybot: 40}   # each role's marker above the table
  tool_marker: {tag: tool, offset_mm: [0, 0, 20]}   # a marker on the tool (eye-to-hand)
  bins:                    # containers at places: their inside and rim, to spread drops over
    garbage_bin: {size_mm: [74, 74], rim_z_mm: -15}
```

The camera mount (eye-in-hand or eye-to-hand, its pose) stays in ``camera:``.
:data:`WORKCELL` declares the section once (:mod:`armtree.config.spec`):
:func:`check_workcell` validates it while the profile loads, with the position of
every problem; :func:`workcell_of` gives skills the parsed :class:`Workcell`; the
JSON Schema (:func:`workcell_schema`) and the key table of docs/profiles.md are
read from it too. Lengths in mm, angles in degrees.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from armtree.errors import ConfigError

from .profile_access import AnyProfile, profile_section
from .spec import Context, Either, Items, MapOf, Number, OneOf, Record, Ref
from .yamlio import MarkedDict

#: Largest length (mm) any key may give: a rig is not kilometres wide, and a bound keeps
#: a typo from turning into a sweep of millions of poses.
MAX_MM = 5000.0
#: Most looks a survey may ask for (viewpoints, rectangle grid points).
MAX_LOOKS = 1000
#: Most radii a ring survey may list (one leg of a sweep each).
MAX_RADII = 8


@dataclass(frozen=True)
class Survey:
    """The region of the table the camera should survey, as the profile wrote it.

    ``ring``: points at ``radius_mm`` from the base axis, ``range_deg`` = [lo, hi]
    base angles ``step_deg`` apart (Showers 2016, appendix B); with several radii
    (``radii_mm``) each angle is looked at from each radius, so a band wider than
    one image is covered in every leg. ``rectangle``: a grid
    ``step_mm`` apart over ``x_mm`` x ``y_mm``. ``viewpoints``: explicit table
    points ``[x, y]`` (on the table top) or ``[x, y, z]``.
    """

    shape: str
    radius_mm: float = 0.0
    range_deg: tuple[float, float] = (-100.0, 100.0)
    step_deg: float = 5.0
    x_mm: tuple[float, float] = (0.0, 0.0)
    y_mm: tuple[float, float] = (0.0, 0.0)
    step_mm: float = 40.0
    points: tuple[tuple[float, ...], ...] = ()
    #: A ring's radii, all looked at from every angle (``radius_mm`` written as a list);
    #: one radius when written as a number.
    radii_mm: tuple[float, ...] = ()


@dataclass(frozen=True)
class ToolMarker:
    """A marker fixed on the tool: its tag role and its centre in the tool frame (mm).

    Durovic 2017 servoes and calibrates with such a marker seen by a fixed camera;
    the offset is the paper's ``G_t_M``, "expected to be known in advance".
    """

    tag: str
    offset_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Bin:
    """A container at a place: its inside ``size_mm`` [x, y] centred on the place's x, y
    (aligned with the base frame's axes) and the height of its rim (base frame, mm).

    Things let go there are spread across the inside rather than dropped on each
    other, and let go high enough to clear the rim and what is already in it.
    """

    size_mm: tuple[float, float]
    rim_z_mm: float


@dataclass(frozen=True)
class Workcell:
    """The parsed ``workcell:`` section; a value the profile leaves out is None (or its default)."""

    table_z_mm: float | None = None
    clearance_z_mm: float | None = None
    look_height_mm: float = 120.0
    search_radius_mm: float = 80.0
    grasp_offset_mm: float = 0.0
    release_offset_mm: float = 30.0
    survey: Survey | None = None
    sort: dict[str, str] = field(default_factory=dict)
    marker_heights_mm: dict[str, float] = field(default_factory=dict)
    tool_marker: ToolMarker | None = None
    bins: dict[str, Bin] = field(default_factory=dict)

    def need(self, name: str, what: str) -> Any:
        """The value of key ``name``; :class:`ConfigError` saying how to add it when absent."""
        value = getattr(self, name)
        if value is None:
            raise ConfigError(
                f"{what} needs workcell.{name} in the hardware profile "
                f"({WORKCELL.fields[name].doc}); add it, e.g. workcell: {{{name}: ...}}"
            )
        return value


#: A tag role (a key of ``tags:``) and a place (a key of ``places:``), as values name them.
TAG_ROLE = Ref("tags", "tag role", "its tag role (a key of tags:)")
PLACE = Ref("places", "place", "a place (a key of places:)")


def _mm(doc: str, default: float | None = None, above: float | None = None) -> Number:
    return Number(doc, "mm", default, above=above, bound=MAX_MM)


def _span(name: str) -> Items:
    """``[lo, hi]`` on the table, mm."""
    return Items(
        Number(bound=MAX_MM),
        f"[{name}_lo, {name}_hi] (mm)",
        length=2,
        ordered=True,
        wanted=f"[{name}_lo, {name}_hi] within +/-{MAX_MM:g} (mm), lo <= hi",
    )


def _grid_size(body: MarkedDict, path: str, ctx: Context) -> None:
    """A rectangle's grid must stay within :data:`MAX_LOOKS` looks."""
    step = float(body.get("step_mm", 40.0))
    looks = math.prod(math.ceil((hi - lo) / step) + 1 for lo, hi in (body["x_mm"], body["y_mm"]))
    if looks > MAX_LOOKS:
        ctx.add(
            f"{path}: a grid of {looks} looks (at most {MAX_LOOKS}); make step_mm larger",
            body.mark,
        )


def _survey(shape: str, body: Any) -> Survey:
    if shape == "viewpoints":
        return Survey("viewpoints", points=body)
    if shape == "rectangle":
        return Survey("rectangle", x_mm=body["x_mm"], y_mm=body["y_mm"], step_mm=body["step_mm"])
    radii = body["radius_mm"] if isinstance(body["radius_mm"], tuple) else (body["radius_mm"],)
    return Survey(
        "ring",
        radius_mm=radii[0],
        radii_mm=radii,
        range_deg=body["range_deg"],
        step_deg=body["step_deg"],
    )


_RADIUS = Number(above=0, bound=MAX_MM)
#: The region of the table the camera surveys: a ring, a rectangle or explicit points.
SURVEY = OneOf(
    {
        "ring": Record(
            {
                "radius_mm": Either(
                    (_RADIUS, Items(_RADIUS, min_items=1, max_items=MAX_RADII)),
                    "ring radius (mm), or a list of radii all looked at from every angle",
                    wanted=f"a radius > 0 and <= {MAX_MM:g} (mm), "
                    f"or a list of 1 to {MAX_RADII} such radii",
                ),
                "range_deg": Items(
                    Number(bound=360.0),
                    "[lo, hi] base angles (deg)",
                    (-100.0, 100.0),
                    length=2,
                    ordered=True,
                    wanted="[lo, hi] base angles within +/-360 (deg), lo <= hi",
                ),
                "step_deg": Number(
                    "step (deg)",
                    default=5.0,
                    minimum=0.1,
                    bound=360.0,
                    wanted="a step of 0.1 to 360 (deg)",
                ),
            },
            required=("radius_mm",),
        ),
        "rectangle": Record(
            {
                "x_mm": _span("x"),
                "y_mm": _span("y"),
                "step_mm": Number(
                    "grid step (mm)",
                    default=40.0,
                    minimum=1.0,
                    bound=MAX_MM,
                    wanted=f"a step of 1 to {MAX_MM:g} (mm)",
                ),
            },
            required=("x_mm", "y_mm"),
            rule=_grid_size,
        ),
        "viewpoints": Items(
            Items(
                Number(bound=MAX_MM),
                min_items=2,
                max_items=3,
                wanted="[x, y] or [x, y, z] in mm",
            ),
            "table points [x, y] or [x, y, z] (mm) the camera looks at",
            min_items=1,
            max_items=MAX_LOOKS,
            each=True,
            wanted=f"a list of 1 to {MAX_LOOKS} points [x, y] or [x, y, z] (mm)",
            shape="[[x, y], ...]",
        ),
    },
    "the region of the table the camera surveys for tags: ring, rectangle or viewpoints",
    build=_survey,
)

#: The ``workcell:`` section, declared once: checks, parsing, schema and docs read it.
WORKCELL = Record(
    {
        "table_z_mm": _mm("height of the table top the camera looks at, in the arm's base frame"),
        "clearance_z_mm": _mm(
            "lowest tool height while travelling or looking around: one that clears every object"
        ),
        "look_height_mm": _mm("camera height above the table while surveying", 120.0, 0.0),
        "search_radius_mm": _mm(
            "how far from a place (or a remembered pose) a tag may be and still be the one meant",
            80.0,
            0.0,
        ),
        "grasp_offset_mm": _mm(
            "tool height above an object's marker when gripping (negative: jaws reach around it)",
            0.0,
        ),
        "release_offset_mm": _mm(
            "tool height above the target's marker when letting go: the held object's height "
            "plus a margin",
            30.0,
        ),
        "survey": SURVEY,
        "sort": MapOf(
            PLACE,
            TAG_ROLE,
            "the place (a key of places:) each tag role belongs (sort.yaml)",
            wanted="a mapping of tag role: place name",
        ),
        "marker_heights_mm": MapOf(
            Number(
                unit="mm",
                minimum=0.0,
                bound=MAX_MM,
                wanted="a height >= 0 (mm) of the marker above the table",
            ),
            TAG_ROLE,
            "height (mm) of each tag role's marker above the table when its object stands on "
            "it: a marker seen near that height is put on it along the camera's ray",
        ),
        "tool_marker": Record(
            {
                "tag": TAG_ROLE,
                "offset_mm": Items(
                    Number(bound=MAX_MM),
                    "the marker's centre in the tool frame (mm)",
                    (0.0, 0.0, 0.0),
                    length=3,
                    wanted=f"[x, y, z] within +/-{MAX_MM:g} mm",
                    shape="[x, y, z] mm",
                ),
            },
            required=("tag",),
            doc="the tag role of a marker on the tool and its offset in the tool frame "
            "(eye-to-hand servoing and calibration)",
            wanted="{tag: ROLE, offset_mm: [x, y, z]} (the marker's centre in the tool frame, mm)",
            build=ToolMarker,
        ),
        "bins": MapOf(
            Record(
                {
                    "size_mm": Items(
                        Number(above=0.0, bound=MAX_MM),
                        "[x, y] size of the inside, centred on the place (mm)",
                        length=2,
                        wanted=f"[x, y], each > 0 and <= {MAX_MM:g} (mm)",
                        shape="[x, y] mm",
                    ),
                    "rim_z_mm": Number(
                        "height of the rim",
                        "mm",
                        bound=MAX_MM,
                        wanted=f"a height within +/-{MAX_MM:g} (mm)",
                    ),
                },
                required=("size_mm", "rim_z_mm"),
                wanted="{size_mm: [x, y], rim_z_mm: z} (the inside's size and the rim's height, mm)",
                build=Bin,
            ),
            PLACE,
            "containers at places (a key of places:): things let go there are spread across "
            "the inside and clear the rim and what is already in it",
        ),
    },
    doc="the rig's task geometry the skills use (table, survey region, clearances, tool offsets)",
    wanted="a mapping (table_z_mm, clearance_z_mm, survey, ...)",
    build=Workcell,
)
#: Who needs a key that has no default, for the docs' table.
NEEDED_BY = {
    "table_z_mm": "needed by the skills that look at the table",
    "clearance_z_mm": "needed by the skills that travel",
}


def check_workcell(data: MarkedDict, errors: list[ConfigError]) -> None:
    """Append an error, at its position, for everything wrong in ``data['workcell']``."""
    if data.get("workcell") is not None:
        ctx = Context(data, errors)
        WORKCELL.check(data["workcell"], "workcell", data.value_mark("workcell"), ctx)


def parse_workcell(section: Mapping[str, Any] | None, table_z: float | None = None) -> Workcell:
    """The :class:`Workcell` of an already validated section; ``table_z`` (the profile's
    ``table: {z}``) stands in for a missing ``table_z_mm``."""
    cell = WORKCELL.parse(dict(section or {}))
    if cell.table_z_mm is None and table_z is not None:
        cell = replace(cell, table_z_mm=float(table_z))
    return cell


def workcell_of(profile: AnyProfile | None) -> Workcell:
    """The :class:`Workcell` of a profile (a :class:`~armtree.loader.profile.Profile` or a plain mapping)."""
    table = profile_section(profile, "table")
    table_z = table.get("z") if isinstance(table, Mapping) else table
    return parse_workcell(
        profile_section(profile, "workcell"), None if table_z is None else float(table_z)
    )


def workcell_schema() -> dict[str, Any]:
    """The JSON Schema of the ``workcell:`` section."""
    return WORKCELL.schema()


__all__ = [
    "PLACE",
    "SURVEY",
    "TAG_ROLE",
    "WORKCELL",
    "Bin",
    "Survey",
    "ToolMarker",
    "Workcell",
    "check_workcell",
    "parse_workcell",
    "workcell_of",
    "workcell_schema",
]
