"""What "the same tree" means for the BehaviorTree.CPP round trip: every node in order with
its depth, path, type and parameters, and the tree's own keys."""

from __future__ import annotations

from typing import Any

import armtree


def shape(tree: armtree.Tree) -> dict[str, Any]:
    """The tree as comparable data (descriptions compared without surrounding space)."""
    nodes: list[tuple[int, str, str, dict[str, Any]]] = []
    todo = [(tree.root, 0)]
    while todo:
        behaviour, depth = todo.pop()
        info = tree.nodes.get(behaviour.id)
        nodes.append(
            (
                depth,
                info.path if info else behaviour.name,
                info.type if info else type(behaviour).__name__,
                dict(info.params) if info else {},
            )
        )
        todo.extend((child, depth + 1) for child in reversed(behaviour.children))
    return {
        "name": tree.name,
        "tick_hz": tree.tick_hz,
        "description": tree.description.strip(),
        "blackboard": tree.blackboard,
        "expect": [
            (e.predicate, e.value, e.subject, e.every, dict(e.options)) for e in tree.expect
        ],
        "profile": getattr(tree.profile, "name", None),
        "nodes": nodes,
    }
