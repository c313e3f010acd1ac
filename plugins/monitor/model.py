"""The tree as the monitor page draws it, and a tick's statuses as one letter per node.

Nodes are numbered depth first from the root, the order of
:attr:`armtree.runtime.runner.Run.nodes`; a tick's statuses travel as a string with
one letter per node (``R`` running, ``S`` success, ``F`` failure, ``I`` invalid).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import py_trees

from armtree.config.params import Binding
from armtree.loader.tree import Tree
from armtree.runtime.runlog import jsonable

#: One letter per status name.
CODES: dict[str, str] = {"INVALID": "I", "RUNNING": "R", "SUCCESS": "S", "FAILURE": "F"}
#: Status name of each letter.
NAMES: dict[str, str] = {v: k for k, v in CODES.items()}


def status_letters(statuses: Sequence[str]) -> str:
    """``("RUNNING", "INVALID")`` -> ``"RI"``."""
    return "".join([CODES.get(s, "I") for s in statuses])


def shown_param(value: Any) -> Any:
    """A parameter as the page shows it: a binding as ``"{key}"``, the rest JSON-safe."""
    if isinstance(value, Binding):
        return "{" + value.key + "}"
    if isinstance(value, dict):
        return {str(k): shown_param(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [shown_param(v) for v in value]
    return jsonable(value)


def _kind(node: py_trees.behaviour.Behaviour) -> str:
    if isinstance(node, py_trees.composites.Composite):
        return "composite"
    if isinstance(node, py_trees.decorators.Decorator):
        return "decorator"
    return "leaf"


def describe_tree(tree: Tree, nodes: Sequence[py_trees.behaviour.Behaviour]) -> dict[str, Any]:
    """The tree's name, source and nodes as JSON-safe data.

    Each node: ``id`` (its index), ``name``, ``type`` (the YAML node type),
    ``class``, ``kind`` (composite, decorator or leaf), ``path``, ``file``,
    ``line`` and ``column`` of its YAML definition, ``params`` as written
    (bindings as ``"{key}"``), ``doc`` (first line of its class docstring),
    ``children`` (indices) and ``parent``.
    """
    index = {n.id: i for i, n in enumerate(nodes)}
    infos = getattr(tree, "nodes", None) or {}
    described = []
    for i, node in enumerate(nodes):
        info = infos.get(node.id)
        mark = getattr(info, "mark", None)
        doc = (type(node).__doc__ or "").strip().splitlines()
        params = getattr(info, "params", None)
        if not params:
            params = getattr(node, "params", None) or {}
        described.append(
            {
                "id": i,
                "name": node.name,
                "type": getattr(info, "type", None) or type(node).__name__,
                "class": type(node).__name__,
                "kind": _kind(node),
                "path": getattr(info, "path", None) or node.name,
                "file": None if mark is None else str(mark.file),
                "line": None if mark is None else mark.line,
                "column": None if mark is None else mark.column,
                "params": {str(k): shown_param(v) for k, v in params.items()},
                "doc": doc[0] if doc else "",
                "children": [index[c.id] for c in node.children if c.id in index],
                "parent": index.get(node.parent.id) if node.parent is not None else None,
            }
        )
    return {
        "name": getattr(tree, "name", "tree"),
        "description": getattr(tree, "description", "") or "",
        "source": str(getattr(tree, "source", "") or ""),
        "tick_hz": float(getattr(tree, "tick_hz", 20.0) or 20.0),
        "nodes": described,
    }


__all__ = ["CODES", "NAMES", "describe_tree", "shown_param", "status_letters"]
