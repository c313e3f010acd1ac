"""One declaration of a configuration section, from which everything else is read.

A profile section (``workcell:``, ``tags:``, ``watchdog:`` ...) is declared once as
a tree of the nodes here: :class:`Number`, :class:`Items`, :class:`Record`,
:class:`MapOf`, :class:`OneOf`, :class:`Either`, :class:`Ref`, :class:`Choice`,
:class:`Boolean`, :class:`Text` and :class:`Anything`. From that one declaration come

* the load-time checks: :meth:`Spec.check` appends a :class:`ConfigError` at the
  FILE:LINE:COL of every bad value (``--set`` values carry the option as their
  position, so an override is checked by the same declaration);
* the JSON Schema ``armtree schema`` writes (:meth:`Spec.schema`);
* the parsed value the skills read (:meth:`Spec.parse`, a :class:`Record` building
  its dataclass);
* the key table of docs/profiles.md (:func:`key_table`).

Messages read ``PATH: expected WANT, got VALUE``; a node's ``want`` says in words
what it takes and is derived from its bounds unless given. A rule that spans keys
(an id used by two tags, a grid of too many looks) is a :class:`Record`'s
``rule``: the one place a section still says something in code.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from armtree.errors import ConfigError, Mark, did_you_mean, shown

from .yamlio import MarkedDict, MarkedList, error_at


@dataclass
class Context:
    """What a check reads besides its value: the whole profile (for :class:`Ref`) and
    the list errors are appended to."""

    data: Mapping[str, Any]
    errors: list[ConfigError] = field(default_factory=list)

    def add(self, message: str, mark: Mark | None) -> None:
        """Append ``message`` at ``mark``."""
        self.errors.append(error_at(message, mark))

    def names(self, section: str) -> Mapping[str, Any]:
        """The keys of the profile's ``section`` (tags, places); empty when it has none."""
        value = self.data.get(section)
        return value if isinstance(value, Mapping) else {}

    def quiet(self) -> Context:
        """A context on the same profile whose errors go nowhere (to try a value)."""
        return Context(self.data)


class Spec(ABC):
    """A declared value: how it is checked, described in JSON Schema, parsed and named."""

    doc: str = ""
    default: Any = None

    @abstractmethod
    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        """Append an error for everything wrong with ``value`` (written at ``at``);
        True when it is fine."""

    @abstractmethod
    def schema(self) -> dict[str, Any]:
        """The JSON Schema (draft 7) of the value."""

    def parse(self, value: Any) -> Any:
        """The value as the code reads it (a checked value; None stays None)."""
        return value

    def brief(self) -> str:
        """A few words for the value column of a table and for a parent's message."""
        return self.want()

    def want(self) -> str:
        """What an error says the value should be."""
        return ""

    def accepts(self, value: Any, ctx: Context) -> bool:
        """True when ``value`` passes, without reporting anything."""
        return self.check(value, "", None, ctx.quiet())

    def _described(self, schema: dict[str, Any], unit: str = "") -> dict[str, Any]:
        doc = f"{self.doc} ({unit})" if self.doc and unit else self.doc
        if doc:
            schema["description"] = doc
        if self.default is not None:
            schema["default"] = (
                list(self.default) if isinstance(self.default, tuple) else self.default
            )
        return schema


def finite_number(value: Any) -> bool:
    """True for an int or float (not a bool) a float can hold: no inf, nan or 1e400."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an integer of hundreds of digits
        return False


@dataclass(frozen=True)
class Number(Spec):
    """A finite number. ``bound`` is the largest magnitude (a rig is not kilometres wide),
    ``minimum``/``maximum`` inclusive, ``above`` a value it must exceed; ``integer``
    asks for a whole number."""

    doc: str = ""
    unit: str = ""
    default: Any = None
    minimum: float | None = None
    maximum: float | None = None
    above: float | None = None
    bound: float | None = None
    integer: bool = False
    #: The words of an error about the type or a bound (derived when empty) ...
    wanted: str = ""
    #: ... and of one about the range (derived when empty).
    range_wanted: str = ""

    def _typed(self, value: Any) -> bool:
        if self.integer:
            return isinstance(value, int) and not isinstance(value, bool)
        return finite_number(value) and (self.bound is None or abs(value) <= self.bound)

    def _in_range(self, value: float) -> bool:
        return (
            (self.above is None or value > self.above)
            and (self.minimum is None or value >= self.minimum)
            and (self.maximum is None or value <= self.maximum)
        )

    def range_text(self) -> str:
        """The range in words: ``"> 0 and <= 5000"``; empty when unbounded."""
        bounds = ((">", self.above), (">=", self.minimum), ("<=", self.maximum))
        return " and ".join(
            f"{sign} {self._bound(value)}" for sign, value in bounds if value is not None
        )

    def _bound(self, value: float) -> str:
        # an integer's bound in full: 2**63 - 1 is not 9.22337e+18
        return str(int(value)) if self.integer else f"{value:g}"

    def want(self) -> str:
        if self.wanted:
            return self.wanted
        unit = f" ({self.unit})" if self.unit else ""
        noun = "an integer" if self.integer else "a number"
        bound = f" within +/-{self.bound:g}" if self.bound is not None else ""
        return f"{noun}{unit}{bound}"

    def _range_want(self) -> str:
        if self.range_wanted or self.wanted:
            return self.range_wanted or self.wanted
        unit = f" {self.unit}" if self.unit else ""
        return f"{'an integer' if self.integer else 'a number'} {self.range_text()}{unit}"

    def brief(self) -> str:
        kind = "int" if self.integer else self.unit
        return " ".join(p for p in (kind, self.range_text()) if p) or "number"

    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        if not self._typed(value):
            ctx.add(f"{path}: expected {self.want()}, got {shown(value)}", at)
            return False
        if not self._in_range(value):
            ctx.add(f"{path}: expected {self._range_want()}, got {shown(value)}", at)
            return False
        return True

    def schema(self) -> dict[str, Any]:
        out: dict[str, Any] = {"type": "integer" if self.integer else "number"}
        low, high = self.minimum, self.maximum
        if self.bound is not None:
            low = -self.bound if low is None else max(low, -self.bound)
            high = self.bound if high is None else min(high, self.bound)
        if self.above is not None:
            out["exclusiveMinimum"] = self.above
        if low is not None and (self.above is None or low > self.above):
            out["minimum"] = low
        if high is not None:
            out["maximum"] = high
        return self._described(out, self.unit)

    def parse(self, value: Any) -> Any:
        if value is None:
            return None
        return int(value) if self.integer else float(value)


@dataclass(frozen=True)
class Items(Spec):
    """A list of ``item``: ``length`` exactly, or ``min_items`` to ``max_items``.

    ``ordered``: each item <= the next ([lo, hi]). ``each``: a bad item is reported
    at its own position as ``PATH[i]`` (a list of points); otherwise the list is
    reported whole (a vector).
    """

    item: Spec = field(default_factory=lambda: Number())
    doc: str = ""
    default: Any = None
    length: int | None = None
    min_items: int = 0
    max_items: int | None = None
    ordered: bool = False
    each: bool = False
    unit: str = ""
    wanted: str = ""
    #: How a table names the shape (``[x, y, z]``); derived when empty.
    shape: str = ""

    def _count_ok(self, n: int) -> bool:
        if self.length is not None:
            return n == self.length
        return n >= self.min_items and (self.max_items is None or n <= self.max_items)

    def want(self) -> str:
        return self.wanted or f"a list of {self.item.brief()}"

    def brief(self) -> str:
        return self.shape or self.want()

    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        if not isinstance(value, list) or not self._count_ok(len(value)):
            ctx.add(f"{path}: expected {self.want()}, got {shown(value)}", at)
            return False
        if self.each:
            ok = True
            for i, item in enumerate(value):
                mark = value.item_mark(i) if isinstance(value, MarkedList) else at
                ok = self.item.check(item, f"{path}[{i}]", mark, ctx) and ok
            return ok
        if not all(self.item.accepts(v, ctx) for v in value) or (
            self.ordered and any(a > b for a, b in zip(value, value[1:], strict=False))
        ):
            ctx.add(f"{path}: expected {self.want()}, got {shown(value)}", at)
            return False
        return True

    def schema(self) -> dict[str, Any]:
        out: dict[str, Any] = {"type": "array", "items": self.item.schema()}
        if self.length is not None:
            out["minItems"] = out["maxItems"] = self.length
        else:
            if self.min_items:
                out["minItems"] = self.min_items
            if self.max_items is not None:
                out["maxItems"] = self.max_items
        return self._described(out, self.unit)

    def parse(self, value: Any) -> Any:
        if value is None:
            return None
        return tuple(self.item.parse(v) for v in value)


@dataclass(frozen=True)
class Ref(Spec):
    """A string naming a key of the profile's ``section`` (a tag role, a place)."""

    section: str = "tags"
    noun: str = "tag role"
    doc: str = ""

    def want(self) -> str:
        return f"a {self.noun} (a key of {self.section}:)"

    def brief(self) -> str:
        return self.noun

    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        known = ctx.names(self.section)
        if isinstance(value, str) and value in known:
            return True
        ctx.add(f"{path}: {not_named(value, self.noun, self.section, known)}", at)
        return False

    def schema(self) -> dict[str, Any]:
        return self._described({"type": "string"}) | (
            {} if self.doc else {"description": self.want()}
        )

    def parse(self, value: Any) -> Any:
        return None if value is None else str(value)


def not_named(value: Any, noun: str, section: str, known: Mapping[str, Any]) -> str:
    """``'x' is not a place (places: a, b)``."""
    return f"{shown(value)} is not a {noun} ({section}: {', '.join(map(str, known)) or 'none'})"


@dataclass(frozen=True)
class Record(Spec):
    """A mapping with the keys ``fields`` declares; ``required`` must be given.

    ``wanted`` names the whole mapping in a message; ``build`` makes the parsed value
    from the parsed keys (a dataclass); ``rule(value, path, ctx)`` checks what spans
    keys, once every key is fine on its own. ``needs`` overrides how a missing key is
    reported (``"needs id or ids"``).
    """

    fields: Mapping[str, Spec] = field(default_factory=dict)
    required: tuple[str, ...] = ()
    doc: str = ""
    wanted: str = ""
    build: Callable[..., Any] | None = None
    rule: Callable[[MarkedDict, str, Context], None] | None = None
    #: Keys of which exactly one must be given (``id`` or ``ids``).
    one_of: tuple[str, ...] = ()
    #: Name an unknown key by its own path (``PATH.KEY: unknown key 'KEY'``) rather than
    #: the mapping's: a section whose messages always name the offending entry (world:).
    key_paths: bool = False
    #: What leaving the whole record out means, for a key table's default column (its
    #: keys' defaults unless given: ``world.randomize`` left out draws nothing).
    absent: str = ""

    def want(self) -> str:
        return self.wanted or self.brief()

    def brief(self) -> str:
        return "{" + ", ".join(self.fields) + "}"

    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        if not isinstance(value, Mapping):
            ctx.add(f"{path}: expected {self.want()}", at)
            return False
        before = len(ctx.errors)
        marked = value if isinstance(value, MarkedDict) else MarkedDict(value, mark=at)
        for key, item in marked.items():
            spec = self.fields.get(key)
            if spec is None:
                where = f"{path}.{key}" if self.key_paths else path
                ctx.add(
                    f"{where}: unknown key {shown(key)}{unknown_hint(key, self.fields)}",
                    marked.key_mark(key),
                )
            elif item is not None or key in self.required:
                spec.check(item, f"{path}.{key}", marked.value_mark(key), ctx)
        for key in self.required:
            if key not in marked:
                doc = self.fields[key].doc
                ctx.add(f"{path}: needs {key}{f' ({doc})' if doc else ''}", marked.mark or at)
        if self.one_of and sum(key in marked for key in self.one_of) != 1:
            ctx.add(f"{path}: give either {' or '.join(self.one_of)}", marked.mark or at)
        if self.rule is not None and len(ctx.errors) == before:
            self.rule(marked, path, ctx)
        return len(ctx.errors) == before

    def schema(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "type": "object",
            "properties": {k: v.schema() for k, v in self.fields.items()},
        }
        if self.required:
            out["required"] = list(self.required)
        if self.one_of:
            out["oneOf"] = [{"required": [key]} for key in self.one_of]
        out["additionalProperties"] = False
        return self._described(out)

    def parse(self, value: Any) -> Any:
        if value is None:
            return None
        values = {
            key: spec.parse(spec.default if value.get(key) is None else value[key])
            for key, spec in self.fields.items()
        }
        return values if self.build is None else self.build(**values)


def unknown_hint(key: Any, known: Mapping[str, Any] | tuple[str, ...]) -> str:
    """``; did you mean 'x'?``, or the keys there are when no key is close."""
    return did_you_mean(str(key), list(known)) or f" (keys: {', '.join(known)})"


@dataclass(frozen=True)
class MapOf(Spec):
    """A mapping of names to ``value``s; with ``keys`` each name must name a key of another
    section (a tag role, a place)."""

    value: Spec = field(default_factory=lambda: Number())
    keys: Ref | None = None
    doc: str = ""
    default: Any = None
    wanted: str = ""
    key_word: str = "name"
    #: Checks what spans entries (an id used by two tags), once each entry is checked.
    rule: Callable[[MarkedDict, str, Context], None] | None = None
    #: Fewest entries (1: an empty mapping is an error).
    min_entries: int = 0

    def want(self) -> str:
        key = self.keys.noun if self.keys else self.key_word
        return self.wanted or f"a mapping of {key}: {self.value.brief()}"

    def brief(self) -> str:
        key = self.keys.noun.replace(" ", "_") if self.keys else self.key_word
        return f"{{{key}: {self.value.brief()}}}"

    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        if not isinstance(value, Mapping) or len(value) < self.min_entries:
            ctx.add(f"{path}: expected {self.want()}", at)
            return False
        value = value if isinstance(value, MarkedDict) else MarkedDict(value, mark=at)
        before = len(ctx.errors)
        known = ctx.names(self.keys.section) if self.keys else {}
        for name, item in value.items():
            if self.keys is not None and name not in known:
                where = value.key_mark(name)
                ctx.add(
                    f"{path}: {not_named(name, self.keys.noun, self.keys.section, known)}", where
                )
            self.value.check(item, f"{path}.{name}", value.value_mark(name), ctx)
        if self.rule is not None:
            self.rule(value, path, ctx)
        return len(ctx.errors) == before

    def schema(self) -> dict[str, Any]:
        out: dict[str, Any] = {"type": "object", "additionalProperties": self.value.schema()}
        if self.min_entries:
            out["minProperties"] = self.min_entries
        return self._described(out)

    def parse(self, value: Any) -> Any:
        return {str(k): self.value.parse(v) for k, v in (value or {}).items()}


@dataclass(frozen=True)
class OneOf(Spec):
    """A mapping of exactly one key, the name of a shape: ``{ring: {...}}``. Parsed as
    ``build(shape, parsed body)``."""

    shapes: Mapping[str, Spec] = field(default_factory=dict)
    doc: str = ""
    build: Callable[[str, Any], Any] | None = None
    wanted: str = ""

    def want(self) -> str:
        if self.wanted:
            return self.wanted
        named = [f"{name}: {spec.brief()}" for name, spec in self.shapes.items()]
        return f"one of {', '.join(named[:-1])} or {named[-1]}"

    def brief(self) -> str:
        return " / ".join(f"`{name}`" for name in self.shapes)

    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        if (
            not isinstance(value, MarkedDict)
            or len(value) != 1
            or next(iter(value)) not in self.shapes
        ):
            ctx.add(f"{path}: expected {self.want()}", at)
            return False
        shape = next(iter(value))
        return self.shapes[shape].check(
            value[shape], f"{path}.{shape}", value.value_mark(shape), ctx
        )

    def schema(self) -> dict[str, Any]:
        return self._described(
            {
                "oneOf": [
                    {
                        "type": "object",
                        "properties": {name: spec.schema()},
                        "required": [name],
                        "additionalProperties": False,
                    }
                    for name, spec in self.shapes.items()
                ]
            }
        )

    def parse(self, value: Any) -> Any:
        if not value:
            return None
        shape, body = next(iter(value.items()))
        parsed = self.shapes[shape].parse(body)
        return (shape, parsed) if self.build is None else self.build(shape, parsed)


@dataclass(frozen=True)
class Either(Spec):
    """One of ``options`` (a number or a list of numbers); ``wanted`` names them all."""

    options: tuple[Spec, ...] = ()
    doc: str = ""
    default: Any = None
    wanted: str = ""
    unit: str = ""

    def want(self) -> str:
        return self.wanted or " or ".join(o.want() for o in self.options)

    def brief(self) -> str:
        return " or ".join(o.brief() for o in self.options)

    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        for option in self.options:
            if option.accepts(value, ctx):
                return option.check(value, path, at, ctx)
        records = [o for o in self.options if isinstance(o, Record)]
        if isinstance(value, Mapping) and len(records) == 1:
            return records[0].check(value, path, at, ctx)  # the one it meant to be says why
        ctx.add(f"{path}: expected {self.want()}, got {shown(value)}", at)
        return False

    def schema(self) -> dict[str, Any]:
        return self._described({"anyOf": [o.schema() for o in self.options]}, self.unit)

    def parse(self, value: Any) -> Any:
        for option in self.options:
            if option.accepts(value, Context({})):
                return option.parse(value)
        return value


@dataclass(frozen=True)
class _Scalar(Spec):
    """A value of one JSON type, told by its Python type (a subclass names both)."""

    doc: str = ""
    default: Any = None
    python_type: ClassVar[type] = object
    json_type: ClassVar[str] = ""
    words: ClassVar[str] = ""
    short: ClassVar[str] = ""

    def want(self) -> str:
        return self.words

    def brief(self) -> str:
        return self.short

    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        if isinstance(value, self.python_type):
            return True
        ctx.add(f"{path}: expected {self.words}, got {shown(value)}", at)
        return False

    def schema(self) -> dict[str, Any]:
        return self._described({"type": self.json_type})


@dataclass(frozen=True)
class Text(_Scalar):
    """A string."""

    python_type: ClassVar[type] = str
    json_type: ClassVar[str] = "string"
    words: ClassVar[str] = "a string"
    short: ClassVar[str] = "str"


def _word(value: Any) -> str:
    """A value as a YAML file writes it: ``true``, ``wood``."""
    return str(value).lower() if isinstance(value, bool) else str(value)


def _same(value: Any, option: Any) -> bool:
    """``value == option`` without Python's ``0 == False``."""
    return isinstance(value, bool) == isinstance(option, bool) and value == option


@dataclass(frozen=True)
class Choice(Spec):
    """One of ``options`` (a texture, a shape, ``false``). ``advice`` adds a word of its
    own to the error about a wrong value that deserves one."""

    options: tuple[Any, ...] = ()
    doc: str = ""
    default: Any = None
    wanted: str = ""
    advice: Mapping[Any, str] = field(default_factory=dict)

    def want(self) -> str:
        if self.wanted:
            return self.wanted
        words = [_word(o) for o in self.options]
        return " or ".join(words) if len(words) < 3 else f"{', '.join(words[:-1])} or {words[-1]}"

    def brief(self) -> str:
        return " / ".join(f"`{_word(o)}`" for o in self.options)

    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        if any(_same(value, o) for o in self.options):
            return True
        advice = self.advice.get(value) if isinstance(value, str) else None
        names = [o for o in self.options if isinstance(o, str)]
        hint = f"; {advice}" if advice else ""
        if not hint and isinstance(value, str):
            hint = did_you_mean(value, names, list_up_to=0)
        ctx.add(f"{path}: expected {self.want()}, got {shown(value)}{hint}", at)
        return False

    def schema(self) -> dict[str, Any]:
        return self._described({"enum": list(self.options)})


@dataclass(frozen=True)
class Boolean(_Scalar):
    """``true`` or ``false``."""

    python_type: ClassVar[type] = bool
    json_type: ClassVar[str] = "boolean"
    words: ClassVar[str] = "true or false"
    short: ClassVar[str] = "bool"


@dataclass(frozen=True)
class Anything(Spec):
    """Any value: a free-form part (what each calibration recorded)."""

    doc: str = ""

    def check(self, value: Any, path: str, at: Mark | None, ctx: Context) -> bool:
        return True

    def schema(self) -> dict[str, Any]:
        return self._described({})

    def brief(self) -> str:
        return "anything"


def key_table(spec: Record, needed: Mapping[str, str] | None = None) -> str:
    """The Markdown table of a record's keys: key, value, default, meaning.

    ``needed`` says, for a key with no default, who needs it (shown as its default).
    """
    needed = needed or {}
    rows = ["| key | value | default | meaning |", "| --- | --- | --- | --- |"]
    for name, item in spec.fields.items():
        if name in spec.required:
            default = "required"
        elif name in spec.one_of:
            default = "one of " + " / ".join(f"`{k}`" for k in spec.one_of)
        elif item.default is not None:
            default = _table_default(item.default)
        elif isinstance(item, MapOf):
            default = "`{}`"
        else:
            default = needed.get(name, "none")
        value = item.brief()
        value = f"`{value}`" if value.startswith(("{", "[")) else value
        cell = (f"`{name}`", value, default, item.doc)
        rows.append("| " + " | ".join(c.replace("|", "\\|") for c in cell) + " |")
    return "\n".join(rows) + "\n"


def _table_default(value: Any) -> str:
    if isinstance(value, bool):
        return _word(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:g}"
    return f"`{value!r}`" if not isinstance(value, (int, str)) else str(value)


__all__ = [
    "Anything",
    "Boolean",
    "Choice",
    "Context",
    "Either",
    "Items",
    "MapOf",
    "Number",
    "OneOf",
    "Record",
    "Ref",
    "Spec",
    "Text",
    "finite_number",
    "key_table",
    "not_named",
    "unknown_hint",
]
