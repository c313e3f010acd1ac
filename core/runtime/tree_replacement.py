"""Replacing a running tree with another between ticks (``--watch``)."""

from __future__ import annotations

from typing import Protocol

import py_trees
from py_trees.blackboard import Blackboard

from armtree.api.rig import Rig
from armtree.loader.tree import Tree
from armtree.runtime.display import NullView
from armtree.runtime.halting import Halter
from armtree.runtime.resources import Resources
from armtree.runtime.run_hooks import RunHooks
from armtree.runtime.runlog import LoggedRun


class ReplaceableRun(LoggedRun, Protocol):
    """What :class:`TreeReplacement` reads of its run, and the two calls that swap its tree."""

    tree: Tree
    rig: Rig | None
    view: NullView
    halter: Halter
    hooks: RunHooks
    resources: Resources

    def install_tree(self, tree: Tree) -> None:
        """Make ``tree`` the run's tree: set it up and track its nodes."""
        ...

    def note_statuses(self, now: float) -> None:
        """Log the statuses the nodes have now (run seconds)."""
        ...


class TreeReplacement:
    """A validated tree waiting to replace a run's tree, and the swap itself.

    :meth:`offer` may be called from any thread; the run's tick thread asks
    :meth:`due` between ticks and then calls :meth:`swap`, which halts the old
    tree, sets the new one up and carries on with the same rig, clock, log and
    blackboard. A tree may replace the running one once the arm has no command
    under way and the tool holds nothing, unless the new tree's first leaf
    commands the tool (a place or a release).
    """

    def __init__(self, run: ReplaceableRun) -> None:
        self._run = run
        self._waiting: Tree | None = None

    def offer(self, tree: Tree) -> None:
        """Swap ``tree`` in at the next safe point; a later offer replaces one still waiting."""
        self._waiting = tree

    @property
    def waiting(self) -> str | None:
        """Why an offered tree still waits (``None`` when none waits)."""
        if self._waiting is None:
            return None
        return self._unsafe(self._waiting) or "the next tick"

    def due(self) -> bool:
        """True when a tree waits and may be swapped in now."""
        return self._waiting is not None and self._unsafe(self._waiting) is None

    def _unsafe(self, tree: Tree) -> str | None:
        arm = getattr(self._run.rig, "arm", None)
        if arm is None:
            return None
        if arm.busy():
            return "the arm is moving"
        tool = getattr(self._run.rig, "tool", None)
        try:
            holding = tool is not None and bool(tool.holding)
        except Exception:  # noqa: BLE001 - no reading: take it as holding
            holding = True
        if holding and "tool" not in getattr(_first_leaf(tree.root), "RESOURCES", ()):
            return "the tool holds something and the new tree does not start by handling it"
        return None

    def swap(self) -> None:
        """Halt the old tree, set the new one up, carry on (on the tick thread)."""
        run = self._run
        tree, self._waiting = self._waiting, None
        if tree is None:
            return
        now = run.clock.now()
        errors = run.halter.halt()
        run.halter.settle()
        run.note_statuses(now)
        run.resources.release_all()
        previous = run.tree
        for key, value in (getattr(tree, "blackboard", None) or {}).items():
            Blackboard.set(key if key.startswith("/") else "/" + key, value)
        run.install_tree(tree)
        run.log.event(
            run.tick_count,
            now,
            "reload",
            source=str(getattr(tree, "source", "") or ""),
            previous=getattr(previous, "name", None),
            halt_errors=errors,
        )
        run.view.message(f"tree replaced at tick {run.tick_count}: {tree.name}")
        run.hooks.notify("armtree_tree_replaced", run=run, previous=previous)


def _first_leaf(node: py_trees.behaviour.Behaviour) -> py_trees.behaviour.Behaviour:
    """The leaf a tree ticks first: down the first children from ``node``."""
    while node.children:
        node = node.children[0]
    return node
