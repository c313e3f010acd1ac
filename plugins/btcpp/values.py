"""Parameter values as BehaviorTree.CPP port strings and back.

A port is text. A blackboard reference (``{key}``, and armtree's ``{{tag}_pose}``)
is written as it is; so is every value of a text port (``type="std::string"``).
A list of numbers or words on a vector port (``std::vector<double>``,
``std::vector<std::string>``) is written as BT.CPP's own converters read it,
``0;0;20``. Any other value is written in YAML's one-line flow syntax (``3``,
``0.5``, ``{x: 1}``, ``'3'`` for the text "3" where a number would be read),
which is how armtree reads it back: the same values a YAML tree file gives.

A port's type comes from the file's ``<TreeNodesModel>``, else from the
registered behaviour of that name, so a hand-written file without a model reads
``mode="on"`` as the text a ``str`` parameter wants, not YAML's ``true``.
"""

from __future__ import annotations

import re
from typing import Any

import yaml

from armtree import ConfigError
from armtree.config.params import Binding
from armtree.config.yamlio import MarkedDict, MarkedList, load_yaml, plain
from armtree.errors import Mark

#: armtree parameter types as BehaviorTree.CPP port types (``any`` has none, as
#: BT.CPP writes none for a port of any type).
PORT_TYPES: dict[str, str] = {
    "str": "std::string",
    "int": "int",
    "float": "double",
    "bool": "bool",
    "status": "BT::NodeStatus",
    "vector": "std::vector<double>",
    "str_list": "std::vector<std::string>",
    "list": "armtree::list",
    "dict": "armtree::dict",
}
#: Port types whose values are text, written and read as they are.
TEXT_TYPES = frozenset({"std::string", "string", "str", "BT::NodeStatus"})

#: Port types whose values BT.CPP reads as ``;``-separated items.
VECTOR_TYPES = frozenset({"std::vector<double>", "std::vector<std::string>", "std::vector<int>"})

#: ``{...}`` with no space, colon or comma inside: a blackboard reference, never YAML.
REFERENCE = re.compile(r"^\{[^\s:,]*\}$")


def is_text_type(port_type: str | None) -> bool:
    """True when a port of ``port_type`` holds text, read and written as it is."""
    return port_type in TEXT_TYPES


def port_text(value: Any, port_type: str | None) -> str:
    """``value`` as the text of a port of ``port_type`` (None: not known)."""
    if (
        port_type in VECTOR_TYPES
        and isinstance(value, (list, tuple))
        and value
        and all(_plain_item(item) for item in value)
    ):
        return ";".join(to_port(item, False) for item in value)
    return to_port(value, is_text_type(port_type))


def _plain_item(item: Any) -> bool:
    """True for a vector item BT.CPP's ``;`` split gives back as it was."""
    if isinstance(item, bool) or not isinstance(item, (int, float, str)):
        return False
    return not isinstance(item, str) or (";" not in item and item.strip() == item != "")


def to_port(value: Any, text: bool) -> str:
    """``value`` as a port string; ``text``: the port holds text (see the module docstring)."""
    if isinstance(value, Binding):
        return reference_to_btcpp("{" + value.key + "}")
    if isinstance(value, str):
        if REFERENCE.match(value):
            return reference_to_btcpp(value)
        if text or _read(value) == value:
            return value
    dumped = yaml.safe_dump(
        [plain(value)], default_flow_style=True, width=2**31, allow_unicode=True
    )
    return dumped.strip()[1:-1]


def _read(text: str) -> Any:
    try:
        return load_yaml(text, "<port>")
    except ConfigError:
        return text


def reference_to_btcpp(text: str) -> str:
    """armtree's absolute key ``{/key}`` as BT.CPP's root-blackboard key ``{@key}``."""
    return "{@" + text[2:] if text.startswith("{/") else text


def from_port(text: str, port: str, port_type: str | None, mark: Mark) -> Any:
    """The value of port ``port`` of ``port_type`` (None: not known) written ``text`` at
    ``mark``: a reference kept as a ``"{key}"`` string (``{=}`` is ``{port}``,
    ``{@key}`` armtree's ``{/key}``), text as it is, a vector's ``a;b;c`` as a list,
    anything else read as YAML (text that is not YAML stays text, for the loader to
    check against the parameter's type)."""
    if REFERENCE.match(text):
        if text == "{=}":
            return "{" + port + "}"
        return "{/" + text[2:] if text.startswith("{@") else text
    if is_text_type(port_type):
        return text
    if port_type in VECTOR_TYPES and not text.lstrip().startswith("["):
        items = MarkedList(mark=mark)
        words = port_type == "std::vector<std::string>"
        for item in text.split(";") if text.strip() else []:
            items.append(item.strip() if words else from_port(item.strip(), port, None, mark))
            items.item_marks.append(mark)
        return items
    try:
        value = load_yaml(text, mark.file)
    except ConfigError:
        return text
    return _moved(value, mark)


def _moved(value: Any, base: Mark) -> Any:
    """Marks of YAML read from an attribute value, moved to where the value was written."""

    def shift(mark: Mark) -> Mark:
        column = base.column + mark.column - 1 if mark.line == 1 else mark.column
        return Mark(base.file, base.line + mark.line - 1, column)

    def at(mark: Mark | None) -> Mark | None:
        return None if mark is None else shift(mark)

    if isinstance(value, MarkedDict):
        value.mark = at(value.mark)
        # a key's or value's mark is never None, so it keeps its type
        value.key_marks = {k: shift(m) for k, m in value.key_marks.items()}
        value.value_marks = {k: shift(m) for k, m in value.value_marks.items()}
        for item in value.values():
            _moved(item, base)
    elif isinstance(value, MarkedList):
        value.mark = at(value.mark)
        value.item_marks = [at(m) for m in value.item_marks]
        for item in value:
            _moved(item, base)
    return value
