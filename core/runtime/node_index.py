"""Where a run's nodes are: each node's path and YAML position, the deepest node with a
status, the leaves still running."""

from __future__ import annotations

from typing import Any

import py_trees
from py_trees.common import Status

from armtree.loader.tree import Tree


class NodeIndex:
    """Finds and names the nodes of the tree a run ticks.

    Paths come from the loader's :class:`~armtree.loader.tree.NodeInfo` when the tree
    has it (``tree.nodes``), else from the nodes' names up to the root.
    :meth:`use` points it at a replacement tree.
    """

    def __init__(self, tree: Tree) -> None:
        self.use(tree)

    def use(self, tree: Tree) -> None:
        """Index ``tree`` (with its ``root``) from now on."""
        self._tree = tree
        self._root: py_trees.behaviour.Behaviour = tree.root

    def info(self, behaviour: py_trees.behaviour.Behaviour) -> Any:
        """The loader's NodeInfo of ``behaviour`` (``None`` if the tree has none)."""
        nodes = getattr(self._tree, "nodes", None)
        return nodes.get(behaviour.id) if nodes else None

    def path_of(self, behaviour: py_trees.behaviour.Behaviour) -> str:
        """The node's path in the tree (``"Root/Branch/Leaf"``), from the loader's NodeInfo if any."""
        info = self.info(behaviour)
        if info is not None and getattr(info, "path", None):
            return info.path
        names = []
        node: Any = behaviour
        while node is not None:
            names.append(node.name)
            node = node.parent
        return "/".join(reversed(names))

    def where(self, behaviour: py_trees.behaviour.Behaviour) -> str:
        """``"path (file:line)"`` of a node, as far as it is known."""
        info = self.info(behaviour)
        mark = getattr(info, "mark", None) if info is not None else None
        path = self.path_of(behaviour)
        return f"{path} ({mark.file}:{mark.line})" if mark is not None else path

    def deepest(self, status: Status) -> py_trees.behaviour.Behaviour | None:
        """The deepest node with ``status`` down from the root, along the last child
        with it at each level (``None`` when the root does not have it)."""
        node = self._root
        if node.status != status:
            return None
        while node.children:
            nxt = next((c for c in reversed(node.children) if c.status == status), None)
            if nxt is None:
                break
            node = nxt
        return node

    def running_leaves(self) -> list[str]:
        """The paths of the leaves that are RUNNING, depth first."""
        return [
            self.path_of(n)
            for n in self._root.iterate()
            if n.status == Status.RUNNING and not n.children
        ]
