"""Parameter declarations: how a behaviour or component says what it accepts.

A behaviour lists its parameters in ``PARAMS``; the loader checks a whole tree
against them before anything runs, the JSON Schema export reads them, and
``armtree plugins`` prints them. Units are part of the declaration so a user
never has to guess millimetres from metres.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from armtree.errors import shown, yaml_kind


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


#: Default of a parameter that must be given.
REQUIRED: Any = _Required()

#: Type names a parameter may declare, with the JSON Schema each maps to.
TYPE_SCHEMAS: dict[str, dict[str, Any]] = {
    "any": {},
    "str": {"type": "string"},
    "int": {"type": "integer"},
    "float": {"type": "number"},
    "bool": {"type": "boolean"},
    "list": {"type": "array"},
    "dict": {"type": "object"},
    "status": {"type": "string", "enum": ["SUCCESS", "FAILURE", "RUNNING", "INVALID"]},
    "vector": {"type": "array", "items": {"type": "number"}},
    "str_list": {"type": "array", "items": {"type": "string"}},
}

#: What a parameter's value names, so the loader can resolve it against the hardware
#: profile before anything moves (``armtree check``). Skills and plugins declare it.
KINDS: dict[str, str] = {
    "": "a plain value",
    "place": "a place name from the profile's places:, an [x, y, z] position (mm) or a {key}",
    "tag_role": "a tag role from the profile's tags: (empty: none)",
    "position": "an [x, y, z] position (mm) in the arm's base frame that the arm must reach",
}


@dataclass(frozen=True)
class ParamKind:
    """What a plain py_trees behaviour's parameter names, as ``typing.Annotated`` metadata.

    ``tag: Annotated[str, TagRole]`` and ``at: Annotated[str, Place]`` in a
    constructor's signature give the parameter the :data:`KINDS` entry ``kind``,
    so ``armtree check`` resolves its value against the profile as it does for
    ``Param(kind=...)``.
    """

    kind: str

    def __post_init__(self) -> None:
        if self.kind not in KINDS or not self.kind:
            raise ValueError(f"kind must be one of {', '.join(repr(k) for k in KINDS if k)}")


#: ``Annotated[str, TagRole]``: a tag role from the profile's ``tags:``.
TagRole = ParamKind("tag_role")
#: ``Annotated[str, Place]``: a place name from the profile's ``places:`` (or, with a
#: list type, an ``[x, y, z]`` position in mm) the arm must reach.
Place = ParamKind("place")
#: ``Annotated[list[float], Position]``: an ``[x, y, z]`` position (mm) the arm must reach.
Position = ParamKind("position")


@dataclass(frozen=True)
class Binding:
    """A parameter bound to a blackboard key with ``"{key}"`` in a tree file."""

    key: str


@dataclass(frozen=True)
class Param:
    """One declared parameter.

    ``type`` is a name from :data:`TYPE_SCHEMAS`; ``io`` is ``"in"`` for a value
    the behaviour reads, ``"out"`` for a blackboard key it writes (then the
    value in the tree must be a ``"{key}"`` binding) and ``"inout"`` for both.
    ``unit`` is ``"mm"``, ``"deg"``, ``"s"``, ``"Hz"`` ... or empty. ``kind`` (see
    :data:`KINDS`) says what the value names: a ``"place"``, a ``"tag_role"`` or a
    ``"position"`` the loader resolves against the profile.

    Valid ranges bound the work a value can cause (a step of 1e-9 degrees, a rate of
    1e-300 Hz): ``minimum`` and ``maximum`` are inclusive, ``exclusive_minimum`` is a
    value the parameter must be greater than (JSON Schema's meanings); for a
    ``vector`` they bound each item. ``length`` is the exact and ``max_items`` the
    largest number of items of a list or vector.
    """

    name: str
    type: str = "any"
    default: Any = REQUIRED
    unit: str = ""
    doc: str = ""
    io: str = "in"
    choices: tuple[Any, ...] = field(default=())
    kind: str = ""
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: float | None = None
    length: int | None = None
    max_items: int | None = None

    def __post_init__(self) -> None:
        if self.type not in TYPE_SCHEMAS:
            raise ValueError(f"parameter {self.name!r}: unknown type {self.type!r}")
        if self.io not in ("in", "out", "inout"):
            raise ValueError(f"parameter {self.name!r}: io must be in, out or inout")
        if self.kind not in KINDS:
            raise ValueError(
                f"parameter {self.name!r}: kind must be one of {', '.join(map(repr, KINDS))}"
            )

    @property
    def bounded(self) -> bool:
        """True when a valid range or item count is declared."""
        return any(
            v is not None
            for v in (
                self.minimum,
                self.maximum,
                self.exclusive_minimum,
                self.length,
                self.max_items,
            )
        )

    def range_text(self) -> str:
        """The declared range in words (``"> 0 and <= 1000"``), empty when unbounded."""
        parts = []
        if self.exclusive_minimum is not None:
            parts.append(f"> {self.exclusive_minimum:g}")
        if self.minimum is not None:
            parts.append(f">= {self.minimum:g}")
        if self.maximum is not None:
            parts.append(f"<= {self.maximum:g}")
        return " and ".join(parts)

    @property
    def required(self) -> bool:
        """True when the tree must give this parameter."""
        return self.default is REQUIRED

    def describe(self) -> str:
        """One line for listings: ``name: type [unit] = default  doc``."""
        unit = f" [{self.unit}]" if self.unit else ""
        default = "" if self.required else f" = {self.default!r}"
        arrow = {"in": "", "out": " (output)", "inout": " (in/out)"}[self.io]
        bounds = self.range_text()
        bounds = f" ({'each ' if self.type == 'vector' else ''}{bounds})" if bounds else ""
        return f"{self.name}: {self.type}{unit}{default}{bounds}{arrow}  {self.doc}".rstrip()

    def json_schema(self) -> dict[str, Any]:
        """The JSON Schema of this parameter's values, a ``"{key}"`` binding always allowed."""
        value = dict(TYPE_SCHEMAS[self.type])
        if self.choices:
            value = {"enum": list(self.choices)}
        bounds = {
            "minimum": self.minimum,
            "maximum": self.maximum,
            "exclusiveMinimum": self.exclusive_minimum,
        }
        bounds = {k: v for k, v in bounds.items() if v is not None}
        if bounds and self.type in ("int", "float"):
            value.update(bounds)
        elif bounds and self.type == "vector":
            value["items"] = {**value["items"], **bounds}
        if self.length is not None and self.type in ("list", "vector", "str_list"):
            value["minItems"] = value["maxItems"] = self.length
        elif self.max_items is not None and self.type in ("list", "vector", "str_list"):
            value["maxItems"] = self.max_items
        if self.doc or self.unit:
            value["description"] = f"{self.doc} ({self.unit})" if self.unit else self.doc
        if not self.required and _json_safe(self.default):
            value["default"] = self.default
        binding = {"type": "string", "pattern": r"^\{[A-Za-z_][\w./]*\}$"}
        if self.io == "out":
            return binding
        return {"anyOf": [value, binding]} if value else {}


def _json_safe(value: Any) -> bool:
    return value is None or isinstance(value, (str, int, float, bool, list, dict))


def check_value(param: Param, value: Any) -> Any:
    """Return ``value`` converted to the parameter's type, or raise ``ValueError``.

    Ints are accepted where floats are declared; nothing else is coerced, so a
    string ``"10"`` for an ``int`` is an error the user sees at load time. A
    declared range or item count is checked too (see :class:`Param`).
    """
    checked = _check_type(param, value)
    if param.bounded and checked is not None:
        _check_bounds(param, checked)
    return checked


def _check_bounds(param: Param, value: Any) -> None:
    unit = f" {param.unit}" if param.unit else ""
    # an ``any`` that holds a number (a camera index or a path) is bounded as a number
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if param.type in ("int", "float") or (param.type == "any" and number):
        if not _in_range(param, value):
            raise ValueError(f"expected a number {param.range_text()}{unit}, got {shown(value)}")
        return
    if not isinstance(value, list):
        return
    if param.length is not None and len(value) != param.length:
        raise ValueError(f"expected {param.length} items, got {len(value)}")
    if param.max_items is not None and len(value) > param.max_items:
        raise ValueError(f"expected at most {param.max_items} items, got {len(value)}")
    if param.type == "vector":
        for v in value:
            if not _in_range(param, v):
                raise ValueError(
                    f"expected numbers {param.range_text()}{unit}, got {shown(v)} in the list"
                )


def _in_range(param: Param, v: float) -> bool:
    if param.exclusive_minimum is not None and not v > param.exclusive_minimum:
        return False
    if param.minimum is not None and not v >= param.minimum:
        return False
    return not (param.maximum is not None and not v <= param.maximum)


def _check_type(param: Param, value: Any) -> Any:
    t = param.type
    if param.choices and value not in param.choices:
        raise ValueError(f"{shown(value)} is not one of {', '.join(map(repr, param.choices))}")
    if t == "any":
        return value
    if t == "str":
        if not isinstance(value, str):
            raise ValueError(f"expected a string, got {_kind(value)}")
        return value
    if t == "bool":
        if not isinstance(value, bool):
            raise ValueError(f"expected true or false, got {_kind(value)}")
        return value
    if t == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"expected an integer, got {_kind(value)}")
        return value
    if t == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"expected a number, got {_kind(value)}")
        if not _finite(value):
            raise ValueError(f"expected a finite number, got {shown(value)}")
        return float(value)
    if t in ("list", "vector", "str_list"):
        if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
            raise ValueError(f"expected a list, got {_kind(value)}")
        if t == "vector":
            for v in value:
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not _finite(v):
                    raise ValueError(f"expected a list of finite numbers, got {shown(value)}")
            return [float(v) for v in value]
        if t == "str_list" and not all(isinstance(v, str) for v in value):
            raise ValueError(f"expected a list of strings, got {shown(value)}")
        return list(value)
    if t == "dict":
        if not isinstance(value, Mapping):
            raise ValueError(f"expected a mapping, got {_kind(value)}")
        return dict(value)
    if t == "status":
        if value not in ("SUCCESS", "FAILURE", "RUNNING", "INVALID"):
            raise ValueError(f"expected SUCCESS, FAILURE, RUNNING or INVALID, got {shown(value)}")
        return value
    raise AssertionError(f"unhandled parameter type {t}")


def _finite(v: float) -> bool:
    """True for a number a float can hold: not inf or nan, not an integer beyond 1.8e308."""
    try:
        return math.isfinite(v)
    except OverflowError:
        return False


def _kind(value: Any) -> str:
    if value is None:
        return "null"
    return f"{yaml_kind(value)} {shown(value)}"
