"""Why a run ends before its tree succeeds, told once: each cause (the tree failed, a
behaviour or a component raised, a component called ``fail()``, an interrupt) becomes the
:class:`End` the run finishes with, its run-log record, the node that failed and the
traceback; and the events components report along the way."""

from __future__ import annotations

import traceback as tb_module
from dataclasses import dataclass, field
from typing import Any

import py_trees
from py_trees.common import Status

from armtree.api.clock import Clock
from armtree.api.rig import Rig
from armtree.errors import HardwareFault
from armtree.hooks.hook_calls import raised_at

from .halting import Halter
from .interrupts import EXIT_INTERRUPTED, Interrupts
from .node_index import NodeIndex
from .runlog import RunLog
from .status_guard import BadStatus

EXIT_SUCCESS = 0
EXIT_FAILURE = 1
EXIT_HARDWARE = 3

#: Events reported by components (``Run.report_event``) kept for the summary.
EVENTS_KEPT = 200


class End(Exception):
    """The tick loop is over for ``status`` (with why, and the exit code it gives)."""

    def __init__(self, status: str, message: str = "", exit_code: int = EXIT_FAILURE) -> None:
        super().__init__(message)
        self.status = status
        self.message = message
        self.exit_code = exit_code


@dataclass(kw_only=True, eq=False)
class FailureReport:
    """What went wrong in one run: the records, the end message, the failed node.

    Each method that describes a cause returns the :class:`End` and writes the
    cause's run-log record at the given tick, on ``clock``'s time (a tree that
    failed has none: its status records tell it). It fills in
    :attr:`failed_node`, :attr:`traceback` and :attr:`running` for the result;
    a node that raised is handed to ``halter`` to be halted even when not
    RUNNING. :attr:`log` is the run's log, replaced by the run when it opens one.
    """

    clock: Clock
    interrupts: Interrupts
    index: NodeIndex
    halter: Halter
    view: Any
    log: RunLog
    #: The first reason a component gave to :meth:`fail` (``None``: none yet).
    fail_reason: str | None = field(default=None, init=False)
    #: The path of the node that raised, or of the deepest failing node.
    failed_node: str | None = field(default=None, init=False)
    #: The traceback of what raised, as text.
    traceback: str | None = field(default=None, init=False)
    #: The leaves that were RUNNING when the run was interrupted or failed.
    running: list[str] | None = field(default=None, init=False)
    #: Notable events components reported, for the summary (the log has them all).
    events: list[dict[str, Any]] = field(default_factory=list, init=False)

    def fail(self, reason: str) -> None:
        """Ask the run to end as FAILURE because of ``reason``; the first reason wins."""
        if self.fail_reason is None:
            self.fail_reason = reason
            self.interrupts.wake.set()

    def event(self, tick: int, event: str, message: str | None = None, **data: Any) -> None:
        """Write a component's event at ``tick``; with a ``message``, show it and keep it
        for the summary (the first :data:`EVENTS_KEPT`)."""
        t = self.clock.now()
        self.log.event(tick, t, event, **data)
        if message:
            self.view.message(f"t={t:.2f}s {message}")
            if len(self.events) < EVENTS_KEPT:
                self.events.append({"tick": tick, "t": t, "event": event, "message": message})

    def component_failed(self, tick: int) -> End:
        """The run ends as FAILURE for the reason a component gave to :meth:`fail`."""
        reason = self.fail_reason or "a component failed"
        self.running = self.index.running_leaves()
        where = f" while {', '.join(self.running)} ran" if self.running else ""
        self.log.event(tick, self.clock.now(), "fail", reason=reason, running=self.running)
        return End("FAILURE", f"{reason}{where}")

    def component_exception(self, tick: int, exc: Exception) -> End:
        """A component's step raised: FAILURE, exit 3 for a hardware fault."""
        self.traceback = "".join(tb_module.format_exception(exc))
        self.log.event(
            tick,
            self.clock.now(),
            "component_error",
            error=f"{type(exc).__name__}: {exc}",
            traceback=self.traceback,
        )
        if isinstance(exc, HardwareFault):
            self.event(tick, "fault", f"fault: {exc}", error=str(exc))
            return End("FAILURE", f"hardware fault: {exc}", EXIT_HARDWARE)
        return End("FAILURE", f"{type(exc).__name__} in a component step: {exc}")

    def behaviour_exception(self, tick: int, exc: BaseException, phase: str) -> End:
        """A behaviour raised in ``phase`` (setup, tick): FAILURE naming the node and its
        YAML position, exit 3 for a hardware fault."""
        node = exc.behaviour if isinstance(exc, BadStatus) else _raising_behaviour(exc)
        self.traceback = "".join(tb_module.format_exception(exc))
        where = self.index.where(node) if node is not None else "the tree"
        self.failed_node = self.index.path_of(node) if node is not None else None
        self.halter.raiser = node
        if isinstance(exc, BadStatus):
            # The plugin's mistake, said in full: no traceback adds to it.
            self.traceback = None
            message = f"bad status at {where}: {exc}"
        else:
            message = f"{type(exc).__name__} in {phase} of {where}{_raised_in(node, exc)}: {exc}"
        self.log.event(
            tick,
            self.clock.now(),
            "exception",
            node=self.failed_node,
            phase=phase,
            error=f"{type(exc).__name__}: {exc}",
            traceback=self.traceback,
        )
        code = EXIT_HARDWARE if isinstance(exc, HardwareFault) else EXIT_FAILURE
        return End("FAILURE", message, code)

    def tree_failed(self, rig: Rig | None) -> End:
        """The root ended FAILURE: a fault a rig component holds is the cause (exit 3),
        else the deepest failing node and its feedback message."""
        fault = component_fault(rig)
        if fault is not None:
            return End("FAILURE", f"hardware fault: {fault}", EXIT_HARDWARE)
        failed = self.index.deepest(Status.FAILURE)
        self.failed_node = self.index.path_of(failed) if failed is not None else None
        if failed is None:
            return End("FAILURE", "FAILURE")
        why = (getattr(failed, "feedback_message", "") or "").strip()
        child = getattr(failed, "decorated", None)
        said = (getattr(child, "feedback_message", "") or "").strip()
        if child is not None and said:
            # A decorator that turned its child's verdict says only "success -> failure":
            # the child's own words are the reason.
            why = f"{why} ({child.name}: {said})" if why else f"{child.name}: {said}"
        return End(
            "FAILURE",
            f"the tree failed at {self.index.where(failed)}" + (f": {why}" if why else ""),
        )

    def note_interrupt(self, tick: int, stuck: str | None) -> str:
        """Record the interrupt the run takes up (and a device fault that caused it);
        ``stuck`` names a tick that did not return. Returns the interrupt's reason."""
        reason = self.interrupts.reason or "interrupt"
        fault = self.interrupts.fault
        self.running = self.index.running_leaves()
        if stuck:
            # The node whose tick never returned is not RUNNING yet, but it is what ran.
            self.running = [stuck, *self.running]
        self.log.event(tick, self.clock.now(), "interrupt", reason=reason, running=self.running)
        self.view.message(f"interrupted: {reason}")
        if fault is not None:
            self.event(tick, "fault", f"fault: {fault}", error=str(fault))
        return reason

    def interrupted(self, tick: int) -> End:
        """INTERRUPTED after :meth:`note_interrupt`: exit 130, or 3 for a device fault."""
        reason = self.interrupts.reason or "interrupt"
        fault = self.interrupts.fault
        where = ", ".join(self.running) if self.running else "no running behaviour"
        message = f"interrupted by {reason} at tick {tick} (t={self.clock.now():.3f} s) in {where}"
        if fault is not None:
            return End("INTERRUPTED", f"{message}: hardware fault: {fault}", EXIT_HARDWARE)
        return End("INTERRUPTED", message, EXIT_INTERRUPTED)


def component_fault(rig: Rig | None) -> HardwareFault | None:
    """A fault a rig component holds (a lost link, a camera that stopped), if any."""
    for part in ("arm", "camera"):
        fault = getattr(getattr(rig, part, None), "fault", None)
        if isinstance(fault, HardwareFault):
            return fault
    return None


def _raised_in(node: Any, exc: BaseException) -> str:
    """`` at FILE:LINE`` of the behaviour's code the exception came from, or ``""``."""
    if node is None or isinstance(exc, HardwareFault):
        return ""
    file, line = raised_at(exc, type(node))
    return f" at {file}:{line}" if file and line else ""


def _raising_behaviour(exc: BaseException) -> py_trees.behaviour.Behaviour | None:
    """The deepest py_trees behaviour whose method is on the exception's traceback."""
    found = None
    tb = exc.__traceback__
    while tb is not None:
        candidate = tb.tb_frame.f_locals.get("self")
        if isinstance(candidate, py_trees.behaviour.Behaviour):
            found = candidate
        tb = tb.tb_next
    return found
