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
    ``unit`` is ``"mm"``, ``"deg"``, ``"s"``, ``"Hz"`` ... or empty.
    """

    name: str
    type: str = "any"
    default: Any = REQUIRED
    unit: str = ""
    doc: str = ""
    io: str = "in"
    choices: tuple[Any, ...] = field(default=())

    def __post_init__(self) -> None:
        if self.type not in TYPE_SCHEMAS:
            raise ValueError(f"parameter {self.name!r}: unknown type {self.type!r}")
        if self.io not in ("in", "out", "inout"):
            raise ValueError(f"parameter {self.name!r}: io must be in, out or inout")

    @property
    def required(self) -> bool:
        """True when the tree must give this parameter."""
        return self.default is REQUIRED

    def describe(self) -> str:
        """One line for listings: ``name: type [unit] = default  doc``."""
        unit = f" [{self.unit}]" if self.unit else ""
        default = "" if self.required else f" = {self.default!r}"
        arrow = {"in": "", "out": " (output)", "inout": " (in/out)"}[self.io]
        return f"{self.name}: {self.type}{unit}{default}{arrow}  {self.doc}".rstrip()

    def json_schema(self) -> dict[str, Any]:
        """The JSON Schema of this parameter's values, a ``"{key}"`` binding always allowed."""
        value = dict(TYPE_SCHEMAS[self.type])
        if self.choices:
            value = {"enum": list(self.choices)}
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
    string ``"10"`` for an ``int`` is an error the user sees at load time.
    """
    t = param.type
    if param.choices and value not in param.choices:
        raise ValueError(f"{value!r} is not one of {', '.join(map(repr, param.choices))}")
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
        if not math.isfinite(value):
            raise ValueError(f"expected a finite number, got {value!r}")
        return float(value)
    if t in ("list", "vector", "str_list"):
        if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
            raise ValueError(f"expected a list, got {_kind(value)}")
        if t == "vector":
            for v in value:
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                    raise ValueError(f"expected a list of finite numbers, got {value!r}")
            return [float(v) for v in value]
        if t == "str_list" and not all(isinstance(v, str) for v in value):
            raise ValueError(f"expected a list of strings, got {value!r}")
        return list(value)
    if t == "dict":
        if not isinstance(value, Mapping):
            raise ValueError(f"expected a mapping, got {_kind(value)}")
        return dict(value)
    if t == "status":
        if value not in ("SUCCESS", "FAILURE", "RUNNING", "INVALID"):
            raise ValueError(f"expected SUCCESS, FAILURE, RUNNING or INVALID, got {value!r}")
        return value
    raise AssertionError(f"unhandled parameter type {t}")


def _kind(value: Any) -> str:
    if value is None:
        return "null"
    return f"{type(value).__name__} {value!r}"
