"""A run's last resorts when it cannot stop by itself: the tick watchdog that leaves a
tick which does not return (naming the node and stopping the arm from another thread),
and the forced exit when a stop hangs too or a second signal comes while stopping."""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import py_trees

from armtree.api.clock import Clock
from armtree.api.rig import Rig
from armtree.api.views import ProfileView
from armtree.config.profile_sections import DEFAULT_TICK_S
from armtree.errors import HardwareFault

from .failure_report import EXIT_HARDWARE, FailureReport
from .halting import Halter
from .interrupts import EXIT_INTERRUPTED, Interrupts
from .node_index import NodeIndex
from .runlog import RunLog
from .watchdog import TickWatchdog, force_exit_later, innermost_code, running_behaviour


@dataclass(kw_only=True, eq=False)
class RunWatchdog:
    """Wires a :class:`~armtree.runtime.watchdog.TickWatchdog` to one run.

    An overrun is an interrupt with a hardware fault (exit 3); the arm is told to
    stop without the run's thread; the node stuck in its tick is named, reported
    as the failed node and halted like one that raised. ``tick()`` gives the run's
    tick count for the records written on a forced exit; :attr:`stopped` is set
    once the run has finished stopping.
    """

    limit_s: float
    stop_timeout: float
    clock: Clock
    interrupts: Interrupts
    halter: Halter
    index: NodeIndex
    report: FailureReport
    tick: Callable[[], int]
    #: The watchdog of the tick loop, once started.
    watch: TickWatchdog | None = field(default=None, init=False)
    #: Set when the run has finished stopping (a forced exit waits for it).
    stopped: threading.Event = field(default_factory=threading.Event, init=False)
    _closed: bool = field(default=False, init=False)
    _rig: Rig | None = field(default=None, init=False)
    _log: RunLog | None = field(default=None, init=False)
    _owns_process: bool = field(default=False, init=False)

    def start(self, *, rig: Rig | None, log: RunLog, owns_process: bool) -> TickWatchdog:
        """Watch the calling thread's ticks; ``owns_process``: the run owns the signals
        (the watchdog leaves a stuck tick with SIGINT, and may end the process)."""
        self._rig, self._log, self._owns_process = rig, log, owns_process
        self.watch = TickWatchdog(
            self.limit_s,
            pending=lambda: self.interrupts.reason,
            on_overrun=self._on_overrun,
            stop_arm=self._request_arm_stop,
            describe=self._describe_stuck,
            use_signal=owns_process,
        )
        self.interrupts.watchdog = self.watch
        self.watch.start()
        return self.watch

    def close(self) -> None:
        """Stop watching (once). After a tick was abandoned, a run that owns the process
        is ended with the cause's code if its stop is stuck as well."""
        watchdog = self.watch
        if watchdog is None or self._closed:
            return
        self._closed = True
        stuck_in = watchdog.phase if watchdog.tick_started is not None else ""
        watchdog.close()
        if watchdog.fired:
            self.halter.rig_stuck = stuck_in == "a component step"
            if self._owns_process:
                # The stop may be stuck as well (a terminate that never returns): the
                # process ends with the cause's code after the stop's own time.
                code = EXIT_HARDWARE if self.interrupts.fault is not None else EXIT_INTERRUPTED
                force_exit_later(self.stop_timeout + 3.0, code, self._last_words, self.stopped)

    def stuck(self) -> str | None:
        """The node (or code) of a tick the watchdog abandoned, for the running list."""
        watchdog = self.watch
        if watchdog is not None and watchdog.fired and watchdog.stuck_in:
            return f"{watchdog.stuck_in} (a tick that did not return)"
        return None

    def force_exit(self, *, key: Any, view: Any, log: RunLog, rig: Rig | None) -> None:
        """Leave the process now (a signal while stopping): the terminal restored, the
        view aborted, a ``forced_exit`` record flushed, the arm told to stop."""
        # Leave the terminal usable: echo back on, cursor shown.
        if key is not None:
            key.restore()
        with contextlib.suppress(Exception):
            view.abort()
        with contextlib.suppress(Exception):
            log.event(self.tick(), self.clock.now(), "forced_exit")
            log.close()
        with contextlib.suppress(Exception):
            if rig is not None:
                rig.stop()
        from .interrupts import _exit_now

        _exit_now()

    def _on_overrun(self, message: str) -> None:
        self.interrupts.request("tick watchdog", HardwareFault(message, "tick watchdog"))

    def _request_arm_stop(self) -> None:
        rig = self._rig
        if rig is None:
            return
        request = getattr(rig, "request_stop", None)
        if callable(request):
            request()
        else:
            threading.Thread(target=rig.stop, name="arm stop", daemon=True).start()

    def _describe_stuck(self, frame: Any) -> str:
        node = running_behaviour(frame, lambda o: isinstance(o, py_trees.behaviour.Behaviour))
        if node is not None:
            # Halted like a node that raised: it may have started something.
            self.halter.raiser = node
            self.report.failed_node = self.index.path_of(node)
            return self.index.where(node)
        return innermost_code(frame)

    def _last_words(self) -> None:
        log = self._log
        if log is not None:
            log.event(self.tick(), self.clock.now(), "forced_exit")
            log.close()


def profile_tick_limit(profile: ProfileView | None) -> float:
    """The profile's ``watchdog: {tick_s: S}``, else the default (wall seconds)."""
    data = getattr(profile, "data", None)
    section = data.get("watchdog") if isinstance(data, dict) else None
    if isinstance(section, dict) and isinstance(section.get("tick_s"), (int, float)):
        return float(section["tick_s"])
    return DEFAULT_TICK_S
