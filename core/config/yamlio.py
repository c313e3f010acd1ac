"""YAML loading that keeps the source position of every node, key and value.

:func:`load_yaml` returns plain Python data whose mappings are :class:`MarkedDict`
and whose lists are :class:`MarkedList`; both behave exactly like ``dict`` and
``list`` but remember where they and each of their entries came from, so the
loaders can report ``FILE:LINE:COL`` for any problem. Scalars stay plain
``str``/``int``/``float``/``bool``/``None``; their positions live in the
container that holds them. Positions are 1-based.

Malformed YAML and duplicate mapping keys raise :class:`armtree.ConfigError`
at the YAML mark.

The front end bounds the work a hostile file can cause before anything walks the
data: files above :data:`MAX_BYTES` are refused unread; the document is built
from the parser's events in one pass without recursion, refusing nesting deeper
than :data:`MAX_DEPTH`, an alias inside the node it names (a cycle) and a
document whose size with every alias expanded passes :data:`MAX_NODES` (the
"billion laughs"); undecodable bytes, control characters and numbers too long
to convert are errors at their line and column. Aliases stay shared (no copy is
made), so every consumer may walk the data as a tree of bounded size.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from yaml.events import (
    AliasEvent,
    DocumentEndEvent,
    DocumentStartEvent,
    MappingEndEvent,
    MappingStartEvent,
    ScalarEvent,
    SequenceEndEvent,
    SequenceStartEvent,
    StreamEndEvent,
    StreamStartEvent,
)
from yaml.nodes import MappingNode, ScalarNode, SequenceNode

from armtree.errors import ConfigError, Mark, shown

try:  # libyaml's parser is several times faster than the pure-Python one
    _Loader: type = yaml.CSafeLoader
except AttributeError:  # pragma: no cover - PyYAML built without libyaml
    _Loader = yaml.SafeLoader


_STR_TAG = "tag:yaml.org,2002:str"
_SEQ_TAG = "tag:yaml.org,2002:seq"
_MAP_TAG = "tag:yaml.org,2002:map"
_MERGE_TAG = "tag:yaml.org,2002:merge"

#: Largest tree or profile file read, in bytes; hand-written files are a few kB.
MAX_BYTES = 2_000_000
#: Most nodes a document may hold with every alias expanded.
MAX_NODES = 200_000
#: Deepest nesting of mappings and lists (a tree of 100 nested nodes needs about 200).
MAX_DEPTH = 200

#: A float in YAML 1.2's core schema that YAML 1.1 leaves a string (no dot, or no exponent sign).
_FLOAT_12 = re.compile(r"^[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)[eE][-+]?[0-9]+$")

#: Characters YAML does not allow in a document (PyYAML's reader rejects the same).
_NOT_PRINTABLE = re.compile(
    "[^\x09\x0a\x0d\x20-\x7e\x85\xa0-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]"
)


class MarkedDict(dict):
    """A ``dict`` that knows where it, each key and each value were written."""

    mark: Mark | None
    key_marks: dict[Any, Mark]
    value_marks: dict[Any, Mark]
    # Declared, not set here: the profile loader sets them on a component's section only
    # once a --set changes its type (the type before, and the keys the new type then
    # drops: value and where), and reads them with getattr's default otherwise.
    swapped_from: Any
    dropped: dict[str, tuple[Any, Mark | None]]

    def __init__(self, *args: Any, mark: Mark | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.mark = mark
        self.key_marks = {}
        self.value_marks = {}

    def key_mark(self, key: Any) -> Mark | None:
        """Where ``key`` was written (the mapping's own position if unknown)."""
        return self.key_marks.get(key, self.mark)

    def value_mark(self, key: Any) -> Mark | None:
        """Where the value of ``key`` was written (else its key's position)."""
        return self.value_marks.get(key) or self.key_mark(key)


class MarkedList(list):
    """A ``list`` that knows where it and each item were written."""

    mark: Mark | None
    item_marks: list[Mark | None]

    def __init__(self, *args: Any, mark: Mark | None = None) -> None:
        super().__init__(*args)
        self.mark = mark
        self.item_marks = []

    def item_mark(self, index: int) -> Mark | None:
        """Where item ``index`` was written (the list's own position if unknown)."""
        if 0 <= index < len(self.item_marks) and self.item_marks[index] is not None:
            return self.item_marks[index]
        return self.mark


def plain(value: Any) -> Any:
    """``value`` with every mapping and list (marked or not) copied as a plain dict or list."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [plain(v) for v in value]
    return value


def error_at(message: str, mark: Mark | None, file: str | None = None) -> ConfigError:
    """A :class:`ConfigError` positioned at ``mark`` (or just naming ``file``).

    A mark of a command-line value (its file starts with ``--``) names the
    option alone: it has no lines to point into.
    """
    if mark is None:
        return ConfigError(message, file=file)
    if mark.file.startswith("--"):
        return ConfigError(message, file=mark.file)
    return ConfigError(message, file=mark.file, line=mark.line, column=mark.column)


def load_yaml(text: str, file: str) -> Any:
    """Parse ``text`` (the contents of ``file``) into marked Python data.

    An empty document gives ``None``. Raises :class:`ConfigError` for malformed
    YAML (at the parser's mark), for a key written twice in one mapping, and for
    the unbounded inputs the module docstring lists.
    """
    bad = _NOT_PRINTABLE.search(text)
    if bad is not None:
        line, column = position_of(text, bad.start())
        raise ConfigError(
            f"character U+{ord(bad.group()):04X} is not allowed in YAML (only tab, newlines "
            "and printable characters); remove it or write it escaped in a quoted string",
            file=file,
            line=line,
            column=column,
        )
    loader = _Loader(text)
    try:
        return _Builder(loader, file).document()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        problem = " ".join(p for p in (exc.context, exc.problem) if p) or "invalid YAML"
        raise ConfigError(
            f"invalid YAML: {problem}",
            file=file,
            line=mark.line + 1 if mark else None,
            column=mark.column + 1 if mark else None,
        ) from None
    except yaml.reader.ReaderError as exc:
        line, column = position_of(text, exc.position)
        raise ConfigError(
            f"invalid YAML: {exc.reason}", file=file, line=line, column=column
        ) from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"invalid YAML: {exc}", file=file) from None
    finally:
        loader.dispose()


def load_yaml_file(path: Path) -> Any:
    """Read and parse one YAML file into marked data (see :func:`load_yaml`).

    A file above :data:`MAX_BYTES`, one that cannot be read and one that is not
    UTF-8 are :class:`ConfigError` (the last at the line and column of the first
    bad byte).
    """
    file = str(path)
    return load_yaml(decode(read_bounded(path), file), file)


def read_bounded(path: Path) -> bytes:
    """The bytes of a tree or profile file; :class:`ConfigError` when it cannot be read
    or is larger than :data:`MAX_BYTES` (then it is not read past the limit)."""
    file = str(path)
    try:
        with open(path, "rb") as stream:
            raw = stream.read(MAX_BYTES + 1)
    except OSError as exc:
        raise ConfigError(f"cannot read {file}: {exc.strerror or exc}", file=file) from None
    if len(raw) > MAX_BYTES:
        raise ConfigError(
            f"the file is larger than {MAX_BYTES:,} bytes, the most armtree reads as a tree "
            "or profile; split it or leave out what it does not need",
            file=file,
        )
    return raw


def decode(raw: bytes, file: str) -> str:
    """``raw`` as UTF-8 text (a byte-order mark dropped); a bad byte is a positioned error."""
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        before = raw[: exc.start]
        line = before.count(b"\n") + 1
        column = len(before[before.rfind(b"\n") + 1 :].decode("utf-8", "replace")) + 1
        raise ConfigError(
            f"byte 0x{raw[exc.start]:02x} is not UTF-8 text; save the file as UTF-8",
            file=file,
            line=line,
            column=column,
        ) from None


def position_of(text: str, index: int) -> tuple[int, int]:
    """1-based line and column of character ``index`` of ``text``."""
    index = max(0, min(index, len(text)))
    line = text.count("\n", 0, index) + 1
    return line, index - (text.rfind("\n", 0, index) + 1) + 1


class _MergeKey:
    """The ``<<`` key of a YAML merge, kept apart from a ``"<<"`` string."""

    def __repr__(self) -> str:
        return "'<<'"


_MERGE: Any = _MergeKey()


def _yaml_mark(mark: Mark | None) -> yaml.Mark | None:
    """Our 1-based mark as PyYAML's 0-based one, for a MarkedYAMLError."""
    if mark is None:
        return None
    return yaml.Mark(mark.file, 0, mark.line - 1, mark.column - 1, None, None)


@dataclass
class _Open:
    """A mapping or list being built, with what its expansion counts so far."""

    value: MarkedDict | MarkedList
    anchor: str | None
    size: int = 1
    key: Any = None
    key_mark: Mark | None = None
    has_key: bool = False
    merges: list[tuple[MarkedDict, Mark]] = field(default_factory=list)


class _Builder:
    """Builds marked data from a parser's events: one pass, an explicit stack, bounded."""

    def __init__(self, loader: Any, file: str) -> None:
        self.loader = loader
        self.file = file
        self.anchors: dict[str, tuple[Any, int]] = {}
        self.stack: list[_Open] = []
        self.expanded = 0
        self.result: Any = None
        self.done = False

    def mark(self, event: Any) -> Mark:
        return Mark(self.file, event.start_mark.line + 1, event.start_mark.column + 1)

    def fail(self, event: Any, problem: str) -> yaml.MarkedYAMLError:
        return yaml.MarkedYAMLError(problem=problem, problem_mark=event.start_mark)

    def document(self) -> Any:
        loader = self.loader
        seen_document = False
        while True:
            event = loader.get_event()
            if isinstance(event, StreamEndEvent):
                return self.result
            if isinstance(event, (StreamStartEvent, DocumentEndEvent)):
                continue
            if isinstance(event, DocumentStartEvent):
                if seen_document:
                    raise self.fail(
                        event, "expected a single document in the file, but found another"
                    )
                seen_document = True
                continue
            self.node(event)

    def count(self, event: Any, size: int) -> None:
        self.expanded += size
        if self.expanded > MAX_NODES:
            raise self.fail(
                event,
                f"the document has more than {MAX_NODES:,} values with its aliases expanded "
                "(an alias bomb?); write them out or split the file",
            )

    def node(self, event: Any) -> None:
        if isinstance(event, ScalarEvent):
            self.count(event, 1)
            value = self.scalar(event)
            if event.anchor is not None:
                self.anchors[event.anchor] = (value, 1)
            self.add(value, 1, event)
        elif isinstance(event, AliasEvent):
            if event.anchor not in self.anchors:
                if any(o.anchor == event.anchor for o in self.stack):
                    raise self.fail(
                        event,
                        f"alias *{event.anchor} refers to the node that contains it "
                        "(a recursive alias); YAML data here must be a tree",
                    )
                raise self.fail(event, f"found undefined alias *{event.anchor}")
            value, size = self.anchors[event.anchor]
            self.count(event, size)
            self.add(value, size, event)
        elif isinstance(event, (SequenceStartEvent, MappingStartEvent)):
            self.start(event)
        elif isinstance(event, (SequenceEndEvent, MappingEndEvent)):
            self.end(event)
        else:  # pragma: no cover - the parser emits nothing else inside a document
            raise self.fail(event, f"unexpected {type(event).__name__}")

    def start(self, event: Any) -> None:
        if len(self.stack) >= MAX_DEPTH:
            raise self.fail(event, f"nesting deeper than {MAX_DEPTH} levels; flatten the structure")
        is_map = isinstance(event, MappingStartEvent)
        kind = MappingNode if is_map else SequenceNode
        tag = event.tag
        if tag is None or tag == "!":
            tag = self.loader.resolve(kind, None, event.implicit)
        if tag != (_MAP_TAG if is_map else _SEQ_TAG):
            raise self.fail(event, f"the tag {tag} is not supported here (plain data only)")
        self.count(event, 1)
        value = MarkedDict(mark=self.mark(event)) if is_map else MarkedList(mark=self.mark(event))
        if event.anchor is not None:
            # Forgotten until the node is complete: an alias to it from inside is a cycle.
            self.anchors.pop(event.anchor, None)
        self.stack.append(_Open(value, event.anchor))

    def end(self, event: Any) -> None:
        done = self.stack.pop()
        if isinstance(done.value, MarkedDict):
            for source, mark in done.merges:
                for key, item in source.items():
                    if key not in done.value:
                        done.value[key] = item
                        done.value.key_marks[key] = source.key_marks.get(key, mark)
                        done.value.value_marks[key] = source.value_marks.get(key, mark)
        if done.anchor is not None:
            self.anchors[done.anchor] = (done.value, done.size)
        self.add(done.value, done.size, None, mark=done.value.mark)

    def scalar(self, event: Any) -> Any:
        tag = event.tag
        if tag is None or tag == "!":
            tag = self.loader.resolve(ScalarNode, event.value, event.implicit)
        if tag == _STR_TAG:
            if not event.style and _FLOAT_12.match(event.value):
                # YAML 1.1 reads 1e6 and 1e-9 as text; YAML 1.2 and every user read numbers.
                return float(event.value)
            return event.value
        if tag == _MERGE_TAG:
            return _MERGE
        node = ScalarNode(tag, event.value, event.start_mark, event.end_mark, style=event.style)
        try:
            return self.loader.construct_object(node, deep=True)
        except (ValueError, OverflowError):  # e.g. an integer of 5,000 digits
            kind = tag.rpartition(":")[2]
            text = (
                event.value
                if len(event.value) <= 40
                else f"{event.value[:20]}... ({len(event.value)} characters)"
            )
            raise self.fail(event, f"cannot read {text!r} as {kind}") from None

    def add(self, value: Any, size: int, event: Any, mark: Mark | None = None) -> None:
        where = mark if mark is not None else self.mark(event)
        if not self.stack:
            self.result = "<<" if value is _MERGE else value
            return
        parent = self.stack[-1]
        parent.size += size
        if isinstance(parent.value, MarkedList):
            parent.value.append("<<" if value is _MERGE else value)
            parent.value.item_marks.append(where)
            return
        if not parent.has_key:
            if isinstance(value, (list, dict)):
                raise yaml.MarkedYAMLError(
                    problem="a mapping key must be a plain value",
                    problem_mark=_yaml_mark(where),
                )
            parent.key, parent.key_mark, parent.has_key = value, where, True
            return
        if value is _MERGE:
            value = "<<"
        key, key_mark = parent.key, parent.key_mark
        if key_mark is None:  # has_key is set with the key's mark
            raise RuntimeError("a mapping's key has no mark")
        parent.key, parent.key_mark, parent.has_key = None, None, False
        if key is _MERGE:
            self.merge(parent, value, where)
            return
        mapping = parent.value
        if key in mapping:
            first = mapping.key_marks[key]
            raise yaml.MarkedYAMLError(
                problem=f"key {shown(key)} is given twice (first at line {first.line})",
                problem_mark=_yaml_mark(key_mark),
            )
        mapping[key] = value
        mapping.key_marks[key] = key_mark
        mapping.value_marks[key] = where

    def merge(self, parent: _Open, value: Any, where: Mark) -> None:
        sources = value if isinstance(value, MarkedList) else [value]
        for source in sources:
            if not isinstance(source, MarkedDict):
                raise yaml.MarkedYAMLError(
                    problem="<< merges a mapping or a list of mappings",
                    problem_mark=_yaml_mark(where),
                )
            parent.merges.append((source, where))
