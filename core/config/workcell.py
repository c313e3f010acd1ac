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
:func:`check_workcell` validates the section while the profile loads, with the
position of every problem; :func:`workcell_of` gives skills the parsed
:class:`Workcell`. :data:`FIELDS` is the one list both read, and the JSON Schema
(:func:`workcell_schema`) is built from it too. Lengths in mm, angles in degrees.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from armtree.errors import ConfigError, did_you_mean

from .profile_access import profile_section
from .yamlio import MarkedDict, MarkedList, error_at

#: The survey shapes and what each takes.
SURVEY_SHAPES = ("ring", "rectangle", "viewpoints")
#: Largest length (mm) any key may give: a rig is not kilometres wide, and a bound keeps
#: a typo from turning into a sweep of millions of poses.
MAX_MM = 5000.0
#: Most looks a survey may ask for (viewpoints, rectangle grid points).
MAX_LOOKS = 1000


@dataclass(frozen=True)
class Field:
    """One scalar key of the section: its unit, doc, default (None: needed by the skills that use it)."""

    name: str
    doc: str
    default: float | None = None
    minimum: float | None = None


#: The scalar keys of ``workcell:`` (mm).
FIELDS: tuple[Field, ...] = (
    Field("table_z_mm", "height of the table top the camera looks at, in the arm's base frame"),
    Field(
        "clearance_z_mm",
        "lowest tool height while travelling or looking around: one that clears every object",
    ),
    Field("look_height_mm", "camera height above the table while surveying", 120.0, 0.0),
    Field(
        "search_radius_mm",
        "how far from a place (or a remembered pose) a tag may be and still be the one meant",
        80.0,
        0.0,
    ),
    Field(
        "grasp_offset_mm",
        "tool height above an object's marker when gripping (negative: jaws reach around it)",
        0.0,
    ),
    Field(
        "release_offset_mm",
        "tool height above the target's marker when letting go: the held object's height plus a margin",
        30.0,
    ),
)
#: Most radii a ring survey may list (one leg of a sweep each).
MAX_RADII = 8
#: Keys of a ring survey: [lo, hi] base angles, the step between looks.
RING_KEYS = ("radius_mm", "range_deg", "step_deg")
#: Keys of a rectangle survey: x and y ranges on the table, the grid step.
RECTANGLE_KEYS = ("x_mm", "y_mm", "step_mm")


@dataclass(frozen=True)
class Survey:
    """The region of the table the camera should survey, as the profile wrote it.

    ``ring``: points at ``radius_mm`` from the base axis, ``range_deg`` = [lo, hi]
    base angles ``step_deg`` apart (seed 004, appendix B); with several radii
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

    Seed 000 servoes and calibrates with such a marker seen by a fixed camera;
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
                f"({_doc(name)}); add it, e.g. workcell: {{{name}: ...}}"
            )
        return value


def _doc(name: str) -> str:
    if name == "survey":
        return "the region the camera surveys: ring, rectangle or viewpoints"
    if name == "tool_marker":
        return "the tag role of a marker on the tool and its offset in the tool frame"
    return next((f.doc for f in FIELDS if f.name == name), name)


def _number(value: Any, bound: float = MAX_MM) -> bool:
    return (
        isinstance(value, (int, float))
        and not isinstance(value, bool)
        and math.isfinite(value)
        and abs(value) <= bound
    )


def _pair(value: Any, bound: float = MAX_MM) -> bool:
    return (
        isinstance(value, list)
        and len(value) == 2
        and all(_number(v, bound) for v in value)
        and value[0] <= value[1]
    )


def _radii(value: Any) -> bool:
    values = value if isinstance(value, list) else [value]
    return 1 <= len(values) <= MAX_RADII and all(_number(v) and v > 0 for v in values)


def check_workcell(data: MarkedDict, errors: list[ConfigError]) -> None:
    """Append an error, at its position, for everything wrong in ``data['workcell']``."""
    cell = data.get("workcell")
    if cell is None:
        return
    if not isinstance(cell, MarkedDict):
        errors.append(
            error_at(
                "workcell: expected a mapping (table_z_mm, clearance_z_mm, survey, ...)",
                data.value_mark("workcell"),
            )
        )
        return
    known = {f.name: f for f in FIELDS}
    for key, value in cell.items():
        where = cell.value_mark(key)
        if key in known:
            spec = known[key]
            if not _number(value):
                errors.append(
                    error_at(
                        f"workcell.{key}: expected a number (mm) within +/-{MAX_MM:g}, got {value!r}",
                        where,
                    )
                )
            elif spec.minimum is not None and value <= spec.minimum:
                errors.append(
                    error_at(
                        f"workcell.{key}: expected a number > {spec.minimum:g} mm, got {value!r}",
                        where,
                    )
                )
        elif key == "survey":
            _check_survey(value, where, errors)
        elif key == "sort":
            _check_sort(value, where, data, errors)
        elif key == "marker_heights_mm":
            _check_heights(value, where, data, errors)
        elif key == "tool_marker":
            _check_tool_marker(value, where, data, errors)
        elif key == "bins":
            _check_bins(value, where, data, errors)
        else:
            choices = [*known, "survey", "sort", "marker_heights_mm", "tool_marker", "bins"]
            errors.append(
                error_at(
                    f"workcell: unknown key {key!r}{did_you_mean(str(key), choices)}",
                    cell.key_mark(key),
                )
            )


def _check_survey(value: Any, where: Any, errors: list[ConfigError]) -> None:
    shapes = [k for k in value if k in SURVEY_SHAPES] if isinstance(value, MarkedDict) else []
    if not isinstance(value, MarkedDict) or len(shapes) != 1 or len(value) != 1:
        errors.append(
            error_at(
                "workcell.survey: expected one of ring: {radius_mm, range_deg, step_deg}, "
                "rectangle: {x_mm, y_mm, step_mm} or viewpoints: [[x, y], ...]",
                where,
            )
        )
        return
    shape = shapes[0]
    spec = value[shape]
    at = value.value_mark(shape)
    path = f"workcell.survey.{shape}"
    if shape == "viewpoints":
        if not isinstance(spec, MarkedList) or not spec or len(spec) > MAX_LOOKS:
            errors.append(
                error_at(
                    f"{path}: expected a list of 1 to {MAX_LOOKS} points [x, y] or [x, y, z] (mm)",
                    at,
                )
            )
            return
        for i, point in enumerate(spec):
            if not (
                isinstance(point, list) and len(point) in (2, 3) and all(_number(v) for v in point)
            ):
                errors.append(
                    error_at(
                        f"{path}[{i}]: expected [x, y] or [x, y, z] in mm, got {point!r}",
                        spec.item_mark(i),
                    )
                )
        return
    keys = RING_KEYS if shape == "ring" else RECTANGLE_KEYS
    if not isinstance(spec, MarkedDict):
        errors.append(error_at(f"{path}: expected a mapping with {', '.join(keys)}", at))
        return
    for key in spec:
        if key not in keys:
            errors.append(
                error_at(
                    f"{path}: unknown key {key!r} (keys: {', '.join(keys)})", spec.key_mark(key)
                )
            )
    checks: dict[str, tuple[Callable[[Any], bool], str]] = {
        "radius_mm": (
            _radii,
            f"a radius > 0 and <= {MAX_MM:g} (mm), or a list of 1 to {MAX_RADII} such radii",
        ),
        "range_deg": (
            lambda v: _pair(v, 360.0),
            "[lo, hi] base angles within +/-360 (deg), lo <= hi",
        ),
        "step_deg": (lambda v: _number(v, 360.0) and v >= 0.1, "a step of 0.1 to 360 (deg)"),
        "x_mm": (lambda v: _pair(v), f"[x_lo, x_hi] within +/-{MAX_MM:g} (mm), lo <= hi"),
        "y_mm": (lambda v: _pair(v), f"[y_lo, y_hi] within +/-{MAX_MM:g} (mm), lo <= hi"),
        "step_mm": (lambda v: _number(v) and v >= 1.0, f"a step of 1 to {MAX_MM:g} (mm)"),
    }
    required = ("radius_mm",) if shape == "ring" else ("x_mm", "y_mm")
    valid = True
    for key in keys:
        if key not in spec:
            if key in required:
                errors.append(error_at(f"{path}: needs {key} ({checks[key][1]})", spec.mark))
            continue
        ok, want = checks[key]
        if not ok(spec[key]):
            errors.append(
                error_at(f"{path}.{key}: expected {want}, got {spec[key]!r}", spec.value_mark(key))
            )
            valid = False
    if shape == "rectangle" and valid:
        step = float(spec.get("step_mm", 40.0))
        looks = math.prod(
            math.ceil((hi - lo) / step) + 1 for lo, hi in (spec["x_mm"], spec["y_mm"])
        )
        if looks > MAX_LOOKS:
            errors.append(
                error_at(
                    f"{path}: a grid of {looks} looks (at most {MAX_LOOKS}); make step_mm larger",
                    at,
                )
            )


def _names(
    value: Any, where: Any, errors: list[ConfigError], want: str, data: MarkedDict, section: str
) -> dict[str, Any] | None:
    """The profile's ``section`` (tags, places) a mapping's keys must name; None, with the
    error ``want`` appended, when ``value`` is no mapping."""
    if not isinstance(value, MarkedDict):
        errors.append(error_at(want, where))
        return None
    names = data.get(section)
    return names if isinstance(names, dict) else {}


def _check_heights(value: Any, where: Any, data: MarkedDict, errors: list[ConfigError]) -> None:
    path = "workcell.marker_heights_mm"
    tags = _names(
        value, where, errors, f"{path}: expected a mapping of tag role: height (mm)", data, "tags"
    )
    if tags is None:
        return
    for role, height in value.items():
        if role not in tags:
            errors.append(_not_a_role(path, role, tags, value))
        if not _number(height) or height < 0:
            errors.append(
                error_at(
                    f"{path}.{role}: expected a height >= 0 (mm) of the marker above the table, "
                    f"got {height!r}",
                    value.value_mark(role),
                )
            )


def _not_a_role(path: str, role: Any, tags: Any, value: MarkedDict) -> ConfigError:
    """``role`` (a key of ``value`` at ``path``) names no tag role of the profile."""
    known = ", ".join(map(str, tags)) or "none"
    return error_at(f"{path}: {role!r} is not a tag role (tags: {known})", value.key_mark(role))


def _check_sort(value: Any, where: Any, data: MarkedDict, errors: list[ConfigError]) -> None:
    tags = _names(
        value,
        where,
        errors,
        "workcell.sort: expected a mapping of tag role: place name",
        data,
        "tags",
    )
    if tags is None:
        return
    places = data.get("places") if isinstance(data.get("places"), dict) else {}
    for role, place in value.items():
        if role not in tags:
            errors.append(_not_a_role("workcell.sort", role, tags, value))
        if not isinstance(place, str) or place not in places:
            errors.append(
                error_at(
                    f"workcell.sort.{role}: {place!r} is not a place (places: {', '.join(map(str, places)) or 'none'})",
                    value.value_mark(role),
                )
            )


def _check_tool_marker(value: Any, where: Any, data: MarkedDict, errors: list[ConfigError]) -> None:
    want = "expected {tag: ROLE, offset_mm: [x, y, z]} (the marker's centre in the tool frame, mm)"
    if not isinstance(value, MarkedDict):
        errors.append(error_at(f"workcell.tool_marker: {want}", where))
        return
    for key in value:
        if key not in ("tag", "offset_mm"):
            errors.append(
                error_at(
                    f"workcell.tool_marker: unknown key {key!r}{did_you_mean(str(key), ['tag', 'offset_mm'])}",
                    value.key_mark(key),
                )
            )
    tags = data.get("tags") if isinstance(data.get("tags"), dict) else {}
    role = value.get("tag")
    if role is None:
        errors.append(error_at(f"workcell.tool_marker: needs tag; {want}", value.mark))
    elif not isinstance(role, str) or role not in tags:
        known = ", ".join(map(str, tags)) or "none"
        errors.append(
            error_at(
                f"workcell.tool_marker.tag: {role!r} is not a tag role (tags: {known})",
                value.value_mark("tag"),
            )
        )
    offset = value.get("offset_mm", [0.0, 0.0, 0.0])
    if not (isinstance(offset, list) and len(offset) == 3 and all(_number(v) for v in offset)):
        errors.append(
            error_at(
                f"workcell.tool_marker.offset_mm: expected [x, y, z] within +/-{MAX_MM:g} mm, "
                f"got {offset!r}",
                value.value_mark("offset_mm") if "offset_mm" in value else value.mark,
            )
        )


def _check_bins(value: Any, where: Any, data: MarkedDict, errors: list[ConfigError]) -> None:
    want = "expected {size_mm: [x, y], rim_z_mm: z} (the inside's size and the rim's height, mm)"
    places = _names(
        value,
        where,
        errors,
        f"workcell.bins: expected a mapping of place name: {want}",
        data,
        "places",
    )
    if places is None:
        return
    for place, spec in value.items():
        path = f"workcell.bins.{place}"
        if place not in places:
            known = ", ".join(map(str, places)) or "none"
            errors.append(
                error_at(
                    f"workcell.bins: {place!r} is not a place (places: {known})",
                    value.key_mark(place),
                )
            )
        if not isinstance(spec, MarkedDict):
            errors.append(error_at(f"{path}: {want}", value.value_mark(place)))
            continue
        for key in spec:
            if key not in ("size_mm", "rim_z_mm"):
                errors.append(
                    error_at(
                        f"{path}: unknown key {key!r}"
                        f"{did_you_mean(str(key), ['size_mm', 'rim_z_mm'])}",
                        spec.key_mark(key),
                    )
                )
        for key in ("size_mm", "rim_z_mm"):
            if key not in spec:
                errors.append(error_at(f"{path}: needs {key}; {want}", spec.mark))
        size = spec.get("size_mm")
        if "size_mm" in spec and not (
            isinstance(size, list) and len(size) == 2 and all(_number(v) and v > 0 for v in size)
        ):
            errors.append(
                error_at(
                    f"{path}.size_mm: expected [x, y], each > 0 and <= {MAX_MM:g} (mm), got {size!r}",
                    spec.value_mark("size_mm"),
                )
            )
        if "rim_z_mm" in spec and not _number(spec["rim_z_mm"]):
            errors.append(
                error_at(
                    f"{path}.rim_z_mm: expected a height within +/-{MAX_MM:g} (mm), "
                    f"got {spec['rim_z_mm']!r}",
                    spec.value_mark("rim_z_mm"),
                )
            )


def parse_workcell(section: Mapping[str, Any] | None, table_z: float | None = None) -> Workcell:
    """The :class:`Workcell` of an already validated section; ``table_z`` (the profile's
    ``table: {z}``) stands in for a missing ``table_z_mm``."""
    cell = dict(section or {})
    values: dict[str, Any] = {f.name: f.default for f in FIELDS}
    values["table_z_mm"] = table_z
    for f in FIELDS:
        if cell.get(f.name) is not None:
            values[f.name] = float(cell[f.name])
    survey = None
    spec = cell.get("survey")
    if isinstance(spec, Mapping) and spec:
        shape, body = next(iter(spec.items()))
        if shape == "viewpoints":
            survey = Survey("viewpoints", points=tuple(tuple(float(v) for v in p) for p in body))
        elif shape == "ring":
            given = body["radius_mm"]
            radii = tuple(float(r) for r in (given if isinstance(given, list) else [given]))
            survey = Survey(
                "ring",
                radius_mm=radii[0],
                radii_mm=radii,
                range_deg=tuple(float(v) for v in body.get("range_deg", (-100.0, 100.0))),  # type: ignore[arg-type]
                step_deg=float(body.get("step_deg", 5.0)),
            )
        else:
            survey = Survey(
                "rectangle",
                x_mm=tuple(float(v) for v in body["x_mm"]),  # type: ignore[arg-type]
                y_mm=tuple(float(v) for v in body["y_mm"]),  # type: ignore[arg-type]
                step_mm=float(body.get("step_mm", 40.0)),
            )
    sort = {str(k): str(v) for k, v in (cell.get("sort") or {}).items()}
    heights = {str(k): float(v) for k, v in (cell.get("marker_heights_mm") or {}).items()}
    marker = cell.get("tool_marker")
    tool_marker = None
    if isinstance(marker, Mapping) and marker.get("tag"):
        offset = marker.get("offset_mm") or (0.0, 0.0, 0.0)
        tool_marker = ToolMarker(str(marker["tag"]), tuple(float(v) for v in offset))  # type: ignore[arg-type]
    bins = {
        str(place): Bin(
            tuple(float(v) for v in spec["size_mm"]),  # type: ignore[arg-type]
            float(spec["rim_z_mm"]),
        )
        for place, spec in (cell.get("bins") or {}).items()
    }
    return Workcell(
        survey=survey,
        sort=sort,
        marker_heights_mm=heights,
        tool_marker=tool_marker,
        bins=bins,
        **values,
    )


def workcell_of(profile: Any) -> Workcell:
    """The :class:`Workcell` of a profile (a :class:`~armtree.loader.profile.Profile` or a plain mapping)."""
    table = profile_section(profile, "table")
    table_z = table.get("z") if isinstance(table, Mapping) else table
    return parse_workcell(
        profile_section(profile, "workcell"), None if table_z is None else float(table_z)
    )


def workcell_schema() -> dict[str, Any]:
    """The JSON Schema of the ``workcell:`` section."""
    pair = {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2}
    properties: dict[str, Any] = {}
    for f in FIELDS:
        prop: dict[str, Any] = {"type": "number", "description": f"{f.doc} (mm)"}
        if f.minimum is not None:
            prop["exclusiveMinimum"] = f.minimum
        if f.default is not None:
            prop["default"] = f.default
        properties[f.name] = prop
    ring = {
        "type": "object",
        "properties": {
            "radius_mm": {
                "oneOf": [
                    {"type": "number", "exclusiveMinimum": 0},
                    {
                        "type": "array",
                        "items": {"type": "number", "exclusiveMinimum": 0},
                        "minItems": 1,
                        "maxItems": MAX_RADII,
                    },
                ],
                "description": "ring radius (mm), or a list of radii all looked at from every angle",
            },
            "range_deg": {
                **pair,
                "description": "[lo, hi] base angles (deg)",
                "default": [-100, 100],
            },
            "step_deg": {
                "type": "number",
                "exclusiveMinimum": 0,
                "description": "step (deg)",
                "default": 5,
            },
        },
        "required": ["radius_mm"],
        "additionalProperties": False,
    }
    rectangle = {
        "type": "object",
        "properties": {
            "x_mm": {**pair, "description": "[x_lo, x_hi] (mm)"},
            "y_mm": {**pair, "description": "[y_lo, y_hi] (mm)"},
            "step_mm": {
                "type": "number",
                "exclusiveMinimum": 0,
                "description": "grid step (mm)",
                "default": 40,
            },
        },
        "required": ["x_mm", "y_mm"],
        "additionalProperties": False,
    }
    viewpoints = {
        "type": "array",
        "minItems": 1,
        "items": {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 3},
        "description": "table points [x, y] or [x, y, z] (mm) the camera looks at",
    }
    survey = {
        "description": "the region of the table the camera surveys for tags",
        "oneOf": [
            {
                "type": "object",
                "properties": {name: spec},
                "required": [name],
                "additionalProperties": False,
            }
            for name, spec in (("ring", ring), ("rectangle", rectangle), ("viewpoints", viewpoints))
        ],
    }
    properties["survey"] = survey
    properties["marker_heights_mm"] = {
        "type": "object",
        "additionalProperties": {"type": "number", "minimum": 0},
        "description": "height (mm) of each tag role's marker above the table when its object "
        "stands on it: a marker seen near that height is put on it along the camera's ray",
    }
    properties["sort"] = {
        "type": "object",
        "additionalProperties": {"type": "string"},
        "description": "the place (a key of places:) each tag role belongs (sort.yaml)",
    }
    properties["tool_marker"] = {
        "type": "object",
        "description": "a marker fixed on the tool (eye-to-hand servoing and calibration)",
        "properties": {
            "tag": {"type": "string", "description": "its tag role (a key of tags:)"},
            "offset_mm": {
                "type": "array",
                "items": {"type": "number"},
                "minItems": 3,
                "maxItems": 3,
                "description": "the marker's centre in the tool frame (mm)",
                "default": [0, 0, 0],
            },
        },
        "required": ["tag"],
        "additionalProperties": False,
    }
    properties["bins"] = {
        "type": "object",
        "description": "containers at places (a key of places:): things let go there are "
        "spread across the inside and clear the rim and what is already in it",
        "additionalProperties": {
            "type": "object",
            "properties": {
                "size_mm": {
                    "type": "array",
                    "items": {"type": "number", "exclusiveMinimum": 0},
                    "minItems": 2,
                    "maxItems": 2,
                    "description": "[x, y] size of the inside, centred on the place (mm)",
                },
                "rim_z_mm": {"type": "number", "description": "height of the rim (mm)"},
            },
            "required": ["size_mm", "rim_z_mm"],
            "additionalProperties": False,
        },
    }
    return {
        "type": "object",
        "description": "the rig's task geometry the skills use (table, survey region, clearances, tool offsets)",
        "properties": properties,
        "additionalProperties": False,
    }


__all__ = [
    "FIELDS",
    "Bin",
    "Survey",
    "ToolMarker",
    "Workcell",
    "check_workcell",
    "parse_workcell",
    "workcell_of",
    "workcell_schema",
]
