"""Why a run failed: every node's change to FAILURE with its reason, and the chains they form.

The runtime hands :class:`FailureLog` each node that turns FAILURE, with its
``feedback_message``. At the end, :meth:`FailureLog.chain` follows the failure
from the root down to the leaf that caused it, and :meth:`FailureLog.absorbed`
lists the failures a retry or a selector swallowed on the way (each as its own
chain, from the highest node that failed down to its leaf).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

#: Failures kept per run; a tree that fails and retries forever keeps its last ones.
LIMIT = 1000
_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?")


@dataclass(frozen=True)
class NodeFailure:
    """One node turning FAILURE: at which tick and run time (s), its path and its reason."""

    tick: int
    t: float
    path: str
    reason: str

    @property
    def name(self) -> str:
        """The node's own name (the last part of its path)."""
        return self.path.rsplit("/", 1)[-1]

    def to_dict(self) -> dict[str, object]:
        """The record kept in the run's result."""
        return {"tick": self.tick, "t": self.t, "node": self.path, "why": self.reason}


def parent_of(path: str) -> str:
    """The path of a node's parent (``""`` for the root)."""
    return path.rsplit("/", 1)[0] if "/" in path else ""


class FailureLog:
    """The failures of one run, in the order they happened (the last :data:`LIMIT`)."""

    def __init__(self) -> None:
        self.failures: list[NodeFailure] = []
        self.forgotten = 0

    def add(self, tick: int, t: float, path: str, reason: str) -> None:
        """Note that the node at ``path`` turned FAILURE at ``tick`` because of ``reason``."""
        self.failures.append(NodeFailure(tick, t, path, (reason or "").strip()))
        if len(self.failures) > LIMIT:
            del self.failures[: len(self.failures) - LIMIT]
            self.forgotten += 1

    def _down_from(self, top: NodeFailure) -> list[NodeFailure]:
        """``top`` and, at the same tick, the failed child of each node in turn."""
        same_tick = [f for f in self.failures if f.tick == top.tick]
        chain = [top]
        while True:
            children = [f for f in same_tick if parent_of(f.path) == chain[-1].path]
            if not children:
                return chain
            chain.append(children[-1])

    def chain(self, root_path: str) -> list[NodeFailure]:
        """The root's last failure and the failed node below each node, down to a leaf.

        Empty when the root never failed (a timeout, an interrupt, a success).
        """
        tops = [f for f in self.failures if f.path == root_path]
        return self._down_from(tops[-1]) if tops else []

    def absorbed(self, root_path: str) -> list[list[NodeFailure]]:
        """Failures whose parent did not fail with them (a retry or selector went on), as chains.

        The root's own final chain is left out.
        """
        final = {id(f) for f in self.chain(root_path)}
        failed_at = {(f.tick, f.path) for f in self.failures}
        out = []
        for f in self.failures:
            if id(f) in final or f.path == root_path:
                continue
            if (f.tick, parent_of(f.path)) in failed_at:
                continue
            out.append(self._down_from(f))
        return out


def chain_text(chain: Sequence[NodeFailure]) -> str:
    """``"Load a ducky > Try the pick twice (final failure) > Pick the ducky: no ducky seen"``."""
    if not chain:
        return ""
    parts = []
    for i, f in enumerate(chain):
        last = i == len(chain) - 1
        if last:
            parts.append(f"{f.name}: {f.reason}" if f.reason else f.name)
        else:
            parts.append(f"{f.name} ({f.reason})" if f.reason else f.name)
    return " > ".join(parts)


def reason_key(text: str) -> str:
    """``text`` with its numbers replaced by ``N``, so runs that failed alike group together."""
    return _NUMBER.sub("N", text)
