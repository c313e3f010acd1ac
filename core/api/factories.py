"""Registered behaviour factories as a tree calls them: the kind of node each builds
(a leaf, a composite or a decorator) and building one with its name and parameters.

The loader builds trees with these, and the plugin checks try a plugin's behaviours
the same way before a tree names them.
"""

from __future__ import annotations

from typing import Any

import py_trees

from armtree.config.constructor_params import name_argument, takes_signature_params

LEAF, COMPOSITE, DECORATOR = "leaf", "composite", "decorator"


def node_kind(factory: Any) -> str:
    """``"leaf"``, ``"composite"`` or ``"decorator"`` for a registered behaviour factory."""
    kind = getattr(factory, "KIND", None)
    if kind in (LEAF, COMPOSITE, DECORATOR):
        return kind
    if isinstance(factory, type):
        if issubclass(factory, py_trees.decorators.Decorator):
            return DECORATOR
        if issubclass(factory, py_trees.composites.Composite):
            return COMPOSITE
    return LEAF


def construct(factory: Any, name: str, params: dict[str, Any]) -> py_trees.behaviour.Behaviour:
    """Build one node: ``factory(name, **params)``; a plain py_trees behaviour gets its name
    the way its constructor takes it (``name=``, first argument, or set afterwards)."""
    how = name_argument(factory) if takes_signature_params(factory) else "positional"
    if how == "keyword":
        return factory(name=name, **params)
    if how == "positional":
        return factory(name, **params)
    behaviour = factory(**params)
    behaviour.name = name
    return behaviour
