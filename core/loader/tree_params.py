"""A tree file's ``params:``: what it declares, what one instance of it binds, and
the ``{param}`` references they fill in (see :mod:`armtree.loader.tree_loader`)."""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

from armtree.config.params import REQUIRED
from armtree.config.yamlio import MarkedDict, MarkedList
from armtree.errors import Mark, did_you_mean, shown

#: Stands for a required file parameter that was not given, so that what depends on it
#: is not reported a second time.
MISSING: Any = object()

PLACEHOLDER = re.compile(r"\{([A-Za-z_]\w*)\}")
BINDING = re.compile(r"^\{(/?[A-Za-z_][\w./]*)\}$")

#: ``error(message, mark, ctx)``: the loader's error collector (ctx has ``file``).
ErrorSink = Callable[..., None]


class TreeParams:
    """Declares and binds the parameters of tree files, reporting through ``error``.

    A file's ``params:`` is a list of names (all required) or a mapping of
    ``name: {default: V, doc: TEXT}``; a ``subtree``'s ``with:`` (or ``--set`` at
    the top) gives values. A required one not given is an error at the include
    and stands as :data:`MISSING` after, so what depends on it is not reported again.
    """

    def __init__(self, error: ErrorSink) -> None:
        self._error = error

    def declared(self, data: MarkedDict, ctx: Any) -> dict[str, tuple[Any, Mark | None]] | None:
        """A file's ``params:`` as ``{name: (default or REQUIRED, mark)}``; None when undeclared."""
        spec = data.get("params")
        if spec is None:
            return None
        out: dict[str, tuple[Any, Mark | None]] = {}
        if isinstance(spec, MarkedList) and all(isinstance(p, str) for p in spec):
            return {p: (REQUIRED, spec.item_mark(i)) for i, p in enumerate(spec)}
        if not isinstance(spec, MarkedDict):
            self._error(
                "params: expected a mapping of name: {default: V, doc: TEXT} or a list of names",
                data.value_mark("params"),
                ctx,
            )
            return None
        for name, info in spec.items():
            if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z_]\w*", name):
                self._error(
                    f"params: {shown(name)} is not a valid parameter name", spec.key_mark(name), ctx
                )
                continue
            if info is None:
                out[name] = (REQUIRED, spec.key_mark(name))
            elif isinstance(info, MarkedDict) and set(info) <= {"default", "doc"}:
                out[name] = (
                    info.get("default", REQUIRED) if "default" in info else REQUIRED,
                    spec.key_mark(name),
                )
            else:
                self._error(
                    f"params.{name}: expected {{default: V, doc: TEXT}} (both optional)",
                    spec.value_mark(name),
                    ctx,
                )
        return out

    def bind(
        self,
        declared: dict[str, tuple[Any, Mark | None]] | None,
        given: dict[str, Any],
        given_marks: MarkedDict | None,
        ctx: Any,
        where: Mark | None = None,
    ) -> dict[str, Any]:
        """The parameter values of one file instance: given ones, else declared defaults."""
        if declared is None:
            return dict(given)
        values: dict[str, Any] = {}
        for name, value in given.items():
            if name not in declared:
                mark = given_marks.key_mark(name) if given_marks is not None else where
                self._error(
                    f"{ctx.file.name} has no parameter {shown(name)}{did_you_mean(name, declared)}",
                    mark,
                )
                continue
            values[name] = value
        for name, (default, declared_at) in declared.items():
            if name in values:
                continue
            if default is REQUIRED:
                how = (
                    "with: {" + name + ": ...}"
                    if given_marks is not None or where
                    else f"--set {name}=VALUE"
                )
                self._error(
                    f"{ctx.file.name} needs parameter {shown(name)}: give it with {how}",
                    where or declared_at or _file_mark(ctx),
                )
                values[name] = MISSING
            else:
                values[name] = default
        return values


def _file_mark(ctx: Any) -> Mark:
    return Mark(str(ctx.file), 1, 1)


def substitute(value: Any, params: dict[str, Any], namespace: str = "") -> Any:
    """Replace ``{param}`` references by parameter values (see the module docstring).

    With a ``namespace``, a resulting ``"{key}"`` binding that is not a parameter's
    value and not absolute (``"{/key}"``) becomes ``"{namespace/key}"``.
    """
    if not params and not namespace:
        return value
    if isinstance(value, str):
        if "{" not in value:
            return value
        whole = PLACEHOLDER.fullmatch(value)
        if whole and whole.group(1) in params:
            return params[whole.group(1)]
        if any(params.get(name) is MISSING for name in PLACEHOLDER.findall(value)):
            return MISSING

        def text(m: re.Match) -> str:
            v = params.get(m.group(1), m)
            if v is m or isinstance(v, (dict, list)):
                return m.group(0)
            return str(v).lower() if isinstance(v, bool) else str(v)

        out = PLACEHOLDER.sub(text, value) if params else value
        binding = BINDING.match(out) if namespace else None
        if binding and not binding.group(1).startswith("/"):
            return f"{{{namespace}/{binding.group(1)}}}"
        return out
    if isinstance(value, MarkedDict):
        out_map = MarkedDict(mark=value.mark)
        for k, v in value.items():
            out_map[k] = substitute(v, params, namespace)
        out_map.key_marks, out_map.value_marks = value.key_marks, value.value_marks
        return out_map
    if isinstance(value, MarkedList):
        items = MarkedList([substitute(v, params, namespace) for v in value], mark=value.mark)
        items.item_marks = value.item_marks
        return items
    return value


def has_missing(value: Any) -> bool:
    """True when ``value`` depends on a parameter that was not given (already reported)."""
    if value is MISSING:
        return True
    if isinstance(value, dict):
        return any(has_missing(v) for v in value.values())
    if isinstance(value, list):
        return any(has_missing(v) for v in value)
    return False


def placeholders(value: Any, found: set[str] | None = None) -> set[str]:
    """Every ``{name}`` referenced anywhere in ``value``."""
    found = set() if found is None else found
    if isinstance(value, str):
        found.update(PLACEHOLDER.findall(value))
    elif isinstance(value, dict):
        for v in value.values():
            placeholders(v, found)
    elif isinstance(value, list):
        for v in value:
            placeholders(v, found)
    return found
