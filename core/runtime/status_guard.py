"""A behaviour's ``update()`` returns a py_trees Status, or the run ends at that tick.

py_trees turns anything else (``None`` from an ``update()`` that forgot its
``return``, a bool, a string) into INVALID with a log line and ticks on: the tree
then spins without end, every tick returning. :func:`guard_statuses` wraps the
``update()`` of each node whose class is not py_trees' own, so the first value that
is not RUNNING, SUCCESS or FAILURE raises :class:`BadStatus` inside that very tick;
the runtime ends the run as FAILURE (exit 1) with what the exception says: the
node, its class, the file and line of its ``update()`` and the value returned.
INVALID counts as wrong too: it is what py_trees sets for a node that has not run,
never a result of running it.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

import py_trees
from py_trees.common import Status

from armtree.errors import shown

#: What ``update()`` may return.
RESULTS = (Status.RUNNING, Status.SUCCESS, Status.FAILURE)

#: Marks a wrapped ``update`` so a tree set up again (``--watch``) is not wrapped twice.
_GUARDED = "_armtree_status_guard"


class BadStatus(Exception):
    """``update()`` of :attr:`behaviour` returned :attr:`value`, which is no result.

    :attr:`file` and :attr:`line` are where that ``update()`` is defined (None
    when the source is unknown).
    """

    def __init__(self, behaviour: py_trees.behaviour.Behaviour, value: Any, update: Any) -> None:
        self.behaviour = behaviour
        self.value = value
        self.file, self.line = source_of(update)
        cls = type(behaviour)
        where = f" at {self.file}:{self.line}" if self.file else ""
        hint = (
            "did update() forget to return?"
            if value is None
            else "return Status.RUNNING, Status.SUCCESS or Status.FAILURE"
        )
        super().__init__(
            f"behaviour {behaviour.name!r} (class {cls.__qualname__}{where}) returned "
            f"{_described(value)} from update(), not RUNNING, SUCCESS or FAILURE: {hint}"
        )


def _described(value: Any) -> str:
    if isinstance(value, Status):
        return f"Status.{value.name}"
    return shown(value)


def source_of(function: Any) -> tuple[str | None, int | None]:
    """The file and first line of ``function`` (a method, bound or not)."""
    target = inspect.unwrap(getattr(function, "__func__", function))
    code = getattr(target, "__code__", None)
    if code is None:
        return None, None
    return code.co_filename, code.co_firstlineno


def guard_statuses(root: py_trees.behaviour.Behaviour) -> None:
    """Wrap ``update()`` of every node under ``root`` whose class is not py_trees' own."""
    for node in root.iterate():
        guard(node)


def guard(node: py_trees.behaviour.Behaviour) -> None:
    """Make ``node.update()`` raise :class:`BadStatus` instead of returning a non-result."""
    update = node.update
    if getattr(update, _GUARDED, False):
        return
    function = getattr(update, "__func__", None)
    if function is None or function.__module__.split(".")[0] == "py_trees":
        return  # py_trees' own nodes return statuses; a callable set on the instance is left be
    node.update = _checked(node, update)  # type: ignore[method-assign]


def _checked(node: py_trees.behaviour.Behaviour, update: Callable[[], Any]) -> Callable[[], Any]:
    running, success, failure = RESULTS

    def checked() -> Any:
        status = update()
        # Identity tests: the cheapest check on every tick of every leaf.
        if status is running or status is success or status is failure:
            return status
        raise BadStatus(node, status, update)

    setattr(checked, _GUARDED, True)
    return checked


__all__ = ["BadStatus", "RESULTS", "guard", "guard_statuses", "source_of"]
