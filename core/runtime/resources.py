"""Exclusive resources: the arm, the tool and a pan-tilt head, each owned by one behaviour.

py_trees ticks a reactive selector's new branch before it stops the old one, so
two actions could command the arm in the same tick. :class:`Resources` closes
that gap: a behaviour claims its resources before its ``initialise()`` (see
:meth:`armtree.Behaviour.tick`), and a claim halts the previous owner, whose
``terminate(INVALID)`` stops its motion, before the new owner sends anything.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import py_trees
from py_trees.common import Status

#: The resources armtree knows; a behaviour may name others, they are exclusive too.
KNOWN_RESOURCES: tuple[str, ...] = ("arm", "tool", "head")


@dataclass(frozen=True)
class Preemption:
    """One handover: ``resource`` went from ``previous`` (halted) to ``owner``."""

    resource: str
    previous: py_trees.behaviour.Behaviour
    owner: py_trees.behaviour.Behaviour


class Resources:
    """Who owns which resource now.

    ``halt(behaviour)`` is called for a previous owner that is still RUNNING;
    the default stops it with INVALID, which calls its ``terminate(INVALID)``.
    """

    def __init__(self, halt: Callable[[py_trees.behaviour.Behaviour], None] | None = None) -> None:
        self._owners: dict[str, py_trees.behaviour.Behaviour] = {}
        self._halt = halt or (lambda behaviour: behaviour.stop(Status.INVALID))

    def owner(self, resource: str) -> py_trees.behaviour.Behaviour | None:
        """The behaviour that holds ``resource`` and is still RUNNING, or None."""
        holder = self._owners.get(resource)
        if holder is not None and holder.status != Status.RUNNING:
            return None
        return holder

    def claim(
        self, behaviour: py_trees.behaviour.Behaviour, names: Iterable[str]
    ) -> list[Preemption]:
        """Give ``names`` to ``behaviour``, halting each running previous owner first.

        Returns the preemptions made, in the order the previous owners were halted
        (a previous owner holding several of the names is halted once).
        """
        names = tuple(names)
        preempted: list[Preemption] = []
        halted: set[int] = set()
        for name in names:
            previous = self.owner(name)
            if previous is None or previous is behaviour:
                continue
            if id(previous) not in halted:
                halted.add(id(previous))
                self._halt(previous)
            preempted.append(Preemption(name, previous, behaviour))
        for name in names:
            self._owners[name] = behaviour
        return preempted

    def release_all(self) -> None:
        """Forget every owner (at the end of a run)."""
        self._owners.clear()
