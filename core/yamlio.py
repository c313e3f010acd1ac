"""YAML loading that keeps the source position of every node, key and value.

:func:`load_yaml` returns plain Python data whose mappings are :class:`MarkedDict`
and whose lists are :class:`MarkedList`; both behave exactly like ``dict`` and
``list`` but remember where they and each of their entries came from, so the
loaders can report ``FILE:LINE:COL`` for any problem. Scalars stay plain
``str``/``int``/``float``/``bool``/``None``; their positions live in the
container that holds them. Positions are 1-based.

Malformed YAML and duplicate mapping keys raise :class:`armtree.ConfigError`
at the YAML mark.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from .errors import ConfigError, Mark

try:  # libyaml's parser is several times faster than the pure-Python one
    _Loader: type = yaml.CSafeLoader
except AttributeError:  # pragma: no cover - PyYAML built without libyaml
    _Loader = yaml.SafeLoader


_STR_TAG = "tag:yaml.org,2002:str"


class MarkedDict(dict):
    """A ``dict`` that knows where it, each key and each value were written."""

    mark: Mark | None
    key_marks: dict[Any, Mark]
    value_marks: dict[Any, Mark]

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


def mark_of(node: yaml.Node, file: str) -> Mark:
    """The 1-based position where a composed YAML node starts."""
    return Mark(file, node.start_mark.line + 1, node.start_mark.column + 1)


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
    YAML (at the parser's mark) and for a key written twice in one mapping.
    """
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        return _convert(node, loader, file, {})
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        problem = " ".join(p for p in (exc.context, exc.problem) if p) or "invalid YAML"
        raise ConfigError(
            f"invalid YAML: {problem}",
            file=file,
            line=mark.line + 1 if mark else None,
            column=mark.column + 1 if mark else None,
        ) from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"invalid YAML: {exc}", file=file) from None
    finally:
        loader.dispose()


def load_yaml_file(path: Path) -> Any:
    """Read and parse one YAML file into marked data (see :func:`load_yaml`)."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read {path}: {exc}", file=str(path)) from None
    return load_yaml(text, str(path))


def _convert(node: yaml.Node, loader: Any, file: str, seen: dict[int, Any]) -> Any:
    # Aliases share node objects; converting each once keeps anchors cheap and acyclic.
    if id(node) in seen:
        return seen[id(node)]
    if isinstance(node, yaml.ScalarNode):
        if node.tag == _STR_TAG:  # most scalars; skips the constructor's bookkeeping
            return node.value
        return loader.construct_object(node, deep=True)
    if isinstance(node, yaml.SequenceNode):
        out = MarkedList(mark=mark_of(node, file))
        seen[id(node)] = out
        for item in node.value:
            out.append(_convert(item, loader, file, seen))
            out.item_marks.append(mark_of(item, file))
        return out
    if isinstance(node, yaml.MappingNode):
        loader.flatten_mapping(node)
        result = MarkedDict(mark=mark_of(node, file))
        seen[id(node)] = result
        for key_node, value_node in node.value:
            key = _convert(key_node, loader, file, seen)
            if isinstance(key, (list, dict)):
                raise yaml.MarkedYAMLError(
                    problem="a mapping key must be a plain value",
                    problem_mark=key_node.start_mark,
                )
            if key in result:
                first = result.key_marks[key]
                raise yaml.MarkedYAMLError(
                    problem=f"key {key!r} is given twice (first at line {first.line})",
                    problem_mark=key_node.start_mark,
                )
            result[key] = _convert(value_node, loader, file, seen)
            result.key_marks[key] = mark_of(key_node, file)
            result.value_marks[key] = mark_of(value_node, file)
        return result
    raise yaml.MarkedYAMLError(problem="unsupported YAML node", problem_mark=node.start_mark)
