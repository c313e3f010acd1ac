"""Parameters read from a constructor's signature, for py_trees behaviours used as they are.

A plain :class:`py_trees.behaviour.Behaviour` subclass (one that declares no
``PARAMS``) registered through ``armtree_behaviours`` takes its YAML parameters
from its ``__init__``: every keyword a tree may give is a named parameter, a
default makes it optional, and an annotation gives its type (``str``, ``int``,
``float``, ``bool``, lists, mappings, ``Literal[...]`` choices, ``X | None``);
an unannotated parameter, or one whose annotation has no YAML form, accepts
any value. ``typing.Annotated`` with :data:`armtree.TagRole`, :data:`armtree.Place`
or :data:`armtree.Position` says what a value names (``tag: Annotated[str,
TagRole]``), so ``armtree check`` resolves it against the profile as it does a
``Param(kind=...)``. ``name`` (and a decorator's ``child``, a composite's ``children``)
is filled in by the loader. A description of each parameter is taken from the
docstring's ``Args:`` section or ``:param x:`` lines, when present.

:func:`declared_params` is what the loader, the schema and ``armtree plugins``
read: a factory's ``PARAMS`` when it declares them, else these.
"""

from __future__ import annotations

import collections.abc
import inspect
import re
import types
import typing
from typing import Any

import py_trees

from .params import REQUIRED, Param, ParamKind

#: Constructor arguments the loader fills in itself, never given in YAML.
FILLED_BY_LOADER = ("self", "name", "child", "children")

_SCALARS: dict[Any, str] = {str: "str", int: "int", float: "float", bool: "bool"}
_SEQUENCES = (list, tuple, collections.abc.Sequence, collections.abc.MutableSequence)
_MAPPINGS = (dict, collections.abc.Mapping, collections.abc.MutableMapping)


def takes_signature_params(factory: Any) -> bool:
    """True for a py_trees behaviour class that declares no ``PARAMS`` of its own.

    Its parameters are its constructor's (see the module docstring).
    """
    return (
        isinstance(factory, type)
        and issubclass(factory, py_trees.behaviour.Behaviour)
        and not _declares_params(factory)
    )


def _declares_params(cls: type) -> bool:
    for klass in cls.__mro__:
        if "PARAMS" in vars(klass):
            # armtree.Behaviour's empty default is no declaration: its subclasses that
            # take constructor keywords instead are read from the signature too.
            return klass.__module__ != "armtree.api.behaviour" or bool(vars(klass)["PARAMS"])
    return False


def declared_params(factory: Any) -> tuple[Param, ...]:
    """A factory's parameters: its ``PARAMS``, or for a plain py_trees behaviour its constructor's."""
    if takes_signature_params(factory):
        return constructor_params(factory)
    return tuple(getattr(factory, "PARAMS", ()) or ())


def constructor_params(cls: type[object]) -> tuple[Param, ...]:
    """The YAML parameters of ``cls.__init__``: names, defaults, types and docs.

    Positional-only parameters (other than the first, the name) and ``*args`` /
    ``**kwargs`` are not parameters: the loader passes parameters by keyword.
    """
    signature = _signature(cls)
    if signature is None:
        return ()
    hints = _hints(cls.__init__)
    docs = param_docs(cls)
    out = []
    for index, (pname, parameter) in enumerate(signature.parameters.items()):
        if pname in FILLED_BY_LOADER or parameter.kind in (
            inspect.Parameter.VAR_POSITIONAL,
            inspect.Parameter.VAR_KEYWORD,
        ):
            continue
        if parameter.kind is inspect.Parameter.POSITIONAL_ONLY and index <= 1:
            continue  # (self,) name: the loader passes the node's name first
        if parameter.kind is inspect.Parameter.POSITIONAL_ONLY:
            continue
        default = REQUIRED if parameter.default is inspect.Parameter.empty else parameter.default
        annotation = hints.get(pname, parameter.annotation)
        type_name, choices = yaml_type(annotation)
        if choices and default is not REQUIRED and default not in choices and default is not None:
            choices = ()
        out.append(
            Param(
                pname,
                type_name,
                default,
                doc=docs.get(pname, ""),
                choices=tuple(choices),
                kind=param_kind(annotation),
            )
        )
    return tuple(out)


def param_kind(annotation: Any) -> str:
    """The :data:`armtree.config.params.KINDS` entry an ``Annotated[..., TagRole]`` (also inside
    ``X | None``) gives; ``""`` for none."""
    if typing.get_origin(annotation) is typing.Annotated:
        found = [m.kind for m in annotation.__metadata__ if isinstance(m, ParamKind)]
        return found[-1] if found else param_kind(typing.get_args(annotation)[0])
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        kinds = {param_kind(a) for a in typing.get_args(annotation)} - {""}
        return kinds.pop() if len(kinds) == 1 else ""
    return ""


def name_argument(cls: type) -> str | None:
    """How the constructor takes the node's name: ``"keyword"`` (a ``name`` parameter),
    ``"positional"`` (a positional-only first parameter) or None (it takes none)."""
    signature = _signature(cls)
    if signature is None:
        return "positional"
    params = [p for n, p in signature.parameters.items() if n != "self"]
    named = signature.parameters.get("name")
    if named is not None and named.kind is not inspect.Parameter.POSITIONAL_ONLY:
        return "keyword"
    if params and params[0].kind is inspect.Parameter.POSITIONAL_ONLY:
        return "positional"
    return None


def _signature(cls: type[object]) -> inspect.Signature | None:
    try:
        return inspect.signature(cls.__init__)
    except (TypeError, ValueError):
        return None


def _hints(function: Any) -> dict[str, Any]:
    """Resolved annotations (``Annotated`` kept); one that does not resolve is left to the
    raw signature."""
    try:
        return typing.get_type_hints(function, include_extras=True)
    except Exception:  # noqa: BLE001 - a forward reference that does not resolve means "any"
        return {}


def yaml_type(annotation: Any) -> tuple[str, tuple[Any, ...]]:
    """The :data:`armtree.config.params.TYPE_SCHEMAS` name and choices for a Python annotation.

    ``"any"`` for no annotation, a string that did not resolve, or a type with no
    YAML form (a class of the plugin's own, say).
    """
    if annotation is inspect.Parameter.empty or annotation is Any or isinstance(annotation, str):
        return "any", ()
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return yaml_type(typing.get_args(annotation)[0])
    args = typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        rest = [a for a in args if a is not type(None)]
        return yaml_type(rest[0]) if len(rest) == 1 else ("any", ())
    if origin is typing.Literal:
        kinds = {_SCALARS.get(type(a), "any") for a in args}
        return (kinds.pop() if len(kinds) == 1 else "any"), tuple(args)
    if annotation in _SCALARS:
        return _SCALARS[annotation], ()
    if annotation in _SEQUENCES or origin in _SEQUENCES:
        items = {a for a in args if a is not Ellipsis}
        if items == {str}:
            return "str_list", ()
        if items and items <= {float, int}:
            return "vector", ()
        return "list", ()
    if annotation in _MAPPINGS or origin in _MAPPINGS:
        return "dict", ()
    return "any", ()


_ARGS_LINE = re.compile(r"^(\w+)\s*(?:\([^)]*\))?\s*:\s*(.*)$")
_SPHINX_LINE = re.compile(r":param\s+(?:[^:]*\s)?(\w+)\s*:\s*(.*)")


def param_docs(cls: type[object]) -> dict[str, str]:
    """``{parameter: first line of its description}`` from the class or ``__init__`` docstring.

    Reads a Google-style ``Args:`` section (``mark (str): the mark to leave``)
    and Sphinx-style ``:param mark: ...`` lines.
    """
    docs: dict[str, str] = {}
    for text in (inspect.getdoc(cls.__init__), inspect.getdoc(cls)):
        if not text:
            continue
        for sphinx in _SPHINX_LINE.finditer(text):
            docs.setdefault(sphinx.group(1), sphinx.group(2).strip())
        lines = text.splitlines()
        for i, line in enumerate(lines):
            if line.strip() not in ("Args:", "Arguments:", "Parameters:"):
                continue
            indent = None
            for entry in lines[i + 1 :]:
                if not entry.strip():
                    continue
                depth = len(entry) - len(entry.lstrip())
                if indent is None:
                    indent = depth
                if depth < indent or depth == 0:
                    break
                match = _ARGS_LINE.match(entry.strip())
                if depth == indent and match:
                    docs.setdefault(match.group(1), match.group(2).strip())
    return docs


__all__ = [
    "constructor_params",
    "declared_params",
    "param_docs",
    "param_kind",
    "name_argument",
    "takes_signature_params",
    "yaml_type",
]
