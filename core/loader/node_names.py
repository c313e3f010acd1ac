"""A node's ``name`` option: ``{param}`` references filled in, checked, the type's name
when absent; read alike for a node the builder makes and a ``subtree:`` node."""

from __future__ import annotations

from armtree.config.yamlio import MarkedDict
from armtree.errors import shown

from .load_context import LoadContext, LoadErrors
from .tree_params import has_missing, substitute


def node_name(options: MarkedDict, ntype: str, ctx: LoadContext, errors: LoadErrors) -> str:
    """The node's ``name`` option (popped from ``options``), checked; ``ntype`` without one."""
    if "name" not in options:
        return ntype
    raw = options.pop("name")
    value = substitute(raw, ctx.params)
    if has_missing(value):
        return ntype
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = str(value)
    if not isinstance(value, str) or not value:
        errors.error(
            f"name: expected a non-empty string, got {shown(raw)}", options.value_mark("name"), ctx
        )
        return ntype
    if "/" in value:
        errors.error(
            f"name: {shown(value)} may not contain '/' (it separates paths)",
            options.value_mark("name"),
            ctx,
        )
    return value
