"""Every node's status from one tick to the next: what the run log, the failure chain
and a view's last frame are made of."""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from typing import Any, Protocol

import py_trees
from py_trees.common import Status

from armtree.api.outcomes.failures import FailureLog
from armtree.runtime.feedback_log import FeedbackLog
from armtree.runtime.runlog import LoggedRun

_FAILURE = Status.FAILURE._value_


class TrackedRun(LoggedRun, Protocol):
    """What :class:`StatusTracker` reads of its run: node paths, and the logs it writes."""

    feedback: FeedbackLog
    failures: FailureLog

    def path_of(self, behaviour: py_trees.behaviour.Behaviour) -> str:
        """The node's path from the root."""
        ...


class StatusTracker:
    """The statuses of one run's nodes, compared tick by tick.

    :meth:`track` logs each change (``status`` records, with why a node failed),
    hands every node that turned FAILURE to the run's failure log with its own
    reason, and keeps for a view each node's last status other than INVALID and
    whether it was halted from RUNNING (:meth:`final`). It reads the run's log,
    feedback log, failure log and tick count as they are at the call.
    """

    def __init__(self, run: TrackedRun) -> None:
        self._run = run
        #: Every node of the tree, depth first from the root.
        self.nodes: list[py_trees.behaviour.Behaviour] = []
        #: Each node's path, in the order of :attr:`nodes`.
        self.paths: tuple[str, ...] = ()
        #: Each node's status name after the last tick (a new tuple only on a change).
        self.last: tuple[str, ...] = ()
        # Per node, for the final frame of a view: its last status other than INVALID
        # (py_trees' halt resets nodes to INVALID) and whether it was halted from RUNNING.
        self._shown: list[str] = []
        self._halted: list[bool] = []
        self._index: dict[str, int] = {}

    def reset(self, root: py_trees.behaviour.Behaviour) -> None:
        """Track the nodes of the tree under ``root`` from their statuses now."""
        self.nodes = list(root.iterate())
        self.paths = tuple(self._run.path_of(n) for n in self.nodes)
        self.last = tuple([n.status._value_ for n in self.nodes])
        self._shown = list(self.last)
        self._halted = [False] * len(self.nodes)
        self._index = {path: i for i, path in enumerate(self.paths)}

    def track(self, now: float, logging: bool, for_view: bool) -> Sequence[tuple[str, str, str]]:
        """Compare every node's status with the last tick's; log the changes when
        ``logging``; return them as ``(path, old, new)`` when ``for_view``."""
        run = self._run
        last = self.last
        # Status names, not members: ``_value_`` is a plain attribute (Enum.value is a
        # slow descriptor), a member's name is always the same str object, and str
        # hashes are cached, so the run log diffs and looks up lines without bytecode.
        current = tuple([n.status._value_ for n in self.nodes])
        changes: Sequence[tuple[str, str, str]] = ()
        if logging:
            run.feedback.record(run.tick_count, now, last, current)
        if current != last:
            self.last = current
            why = self._new_failures(last, current, now) if _FAILURE in current else None
            if logging:
                run.log.status_diff(run.tick_count, now, self.paths, last, current, why)
            if for_view:
                self._remember(last, current)
                changes = [
                    (path, old, new)
                    for path, old, new in zip(self.paths, last, current, strict=True)
                    if old != new
                ]
        return changes

    def feedback_message(self, path: str) -> str:
        """The current ``feedback_message`` of the node at ``path`` ("" if none or unknown)."""
        i = self._index.get(path) if self.nodes else None
        if i is None:
            return ""
        return str(getattr(self.nodes[i], "feedback_message", "") or "")

    def _new_failures(
        self, last: Sequence[str], current: Sequence[str], now: float
    ) -> dict[str, str] | None:
        """Nodes that turned FAILURE this tick, noted with their reason: their feedback
        message, or for a composite or decorator without one, which child failed and why."""
        why: dict[str, str] = {}
        turned = [
            i
            for i, (old, new) in enumerate(zip(last, current, strict=True))
            if new is _FAILURE and old is not _FAILURE
        ]
        for i in turned:
            own = str(getattr(self.nodes[i], "feedback_message", "") or "")
            # The chain of failures shows the child below each node itself.
            self._run.failures.add(self._run.tick_count, now, self.paths[i], own)
        # From the deepest node up, so a parent finds its child's reason.
        for i in sorted(turned, key=lambda i: -_depth(self.nodes[i])):
            node = self.nodes[i]
            reason = str(getattr(node, "feedback_message", "") or "")
            if not reason and node.children:
                reason = self._child_failure(node, why)
            why[self.paths[i]] = reason
        return why or None

    def _child_failure(self, node: py_trees.behaviour.Behaviour, why: dict[str, str]) -> str:
        """``"'child' failed: reason"`` for the child that failed ``node`` (the last one
        that did), or what ``node`` did when no child failed (an inverter's success)."""
        child = next((c for c in reversed(node.children) if c.status == Status.FAILURE), None)
        if child is None:
            shown = ", ".join(f"{c.name!r} {c.status.value}" for c in node.children)
            return f"failed with its children at {shown}"
        path = self._run.path_of(child)
        reason = why.get(path) or str(getattr(child, "feedback_message", "") or "")
        return f"{child.name!r} failed" + (f": {reason}" if reason else "")

    def note_stopped(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        """Log the changes of ``behaviour`` and the nodes below it, halted between ticks."""
        if not self.nodes:
            return
        last = list(self.last)
        for n in behaviour.iterate():
            with contextlib.suppress(ValueError):
                i = self.nodes.index(n)
                name = n.status.value
                if last[i] != name:
                    self._run.log.status_changes(
                        self._run.tick_count,
                        self._run.clock.now(),
                        [(self.paths[i], last[i], name)],
                    )
                    last[i] = name
        self._remember(self.last, last)
        self.last = tuple(last)

    def _remember(self, last: Sequence[str], current: Sequence[str]) -> None:
        shown, halted = self._shown, self._halted
        for i, (old, new) in enumerate(zip(last, current, strict=True)):
            if old == new:
                continue
            if new != "INVALID":
                shown[i], halted[i] = new, False
            elif old == "RUNNING":
                halted[i] = True

    def final(self) -> dict[Any, tuple[str, bool]]:
        """``{node.id: (status name, halted)}``: each node's last status other than INVALID."""
        return {
            n.id: (shown, halted)
            for n, shown, halted in zip(self.nodes, self._shown, self._halted, strict=True)
        }


def _depth(node: py_trees.behaviour.Behaviour) -> int:
    """How many parents ``node`` has."""
    depth = 0
    while node.parent is not None:
        node, depth = node.parent, depth + 1
    return depth
