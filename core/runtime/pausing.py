"""Pausing a run between ticks: where it may hold (an arm with no command under way), and
holding there, the clock stopped and nothing halted, until resumed, stepped or stopped."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from armtree.api.clock import Clock
from armtree.api.rig import Rig

from .control import RunControl
from .interrupts import Interrupts, StopKey
from .pacing import Pacer
from .runlog import RunLog

#: How often the stop key is polled, in wall seconds.
POLL_S = 0.05


@dataclass(kw_only=True, eq=False)
class RunPause:
    """Holds one run between ticks while its ``control`` asks it to (pause, step).

    :meth:`due` says whether to hold before the next tick; :meth:`hold` holds the
    clock through ``pacer``, writes the ``paused`` record and then ``step`` or
    ``resumed`` (not when an interrupt ends the hold), reading the run keys
    meanwhile. Keys typed at any time go to ``control`` (:meth:`read_keys`).
    """

    control: RunControl
    pacer: Pacer
    interrupts: Interrupts
    clock: Clock

    def due(self, rig: Rig | None) -> bool:
        """True when a hold is asked and this is a safe point: on a virtual clock always
        (nothing the runtime steps moves while it stands), otherwise once the arm has
        no command under way."""
        if not self.control.holding:
            return False
        arm = getattr(rig, "arm", None)
        return self.clock.virtual or arm is None or not arm.busy()

    def read_keys(self, keys: StopKey) -> None:
        """Hand the keys typed since the last read to the run's control."""
        typed = keys.read()
        if typed:
            self.control.key(typed)

    def hold(
        self,
        *,
        tick: int,
        log: RunLog,
        keys: StopKey | None,
        announce: Callable[[bool], None],
        show: Callable[[], None],
    ) -> None:
        """Stand still after ``tick`` until resumed, stepped or stopped; ``announce(paused)``
        tells the view and plugins, ``show()`` redraws the view while it waits."""
        control, clock, wake = self.control, self.clock, self.control.wake
        self.pacer.hold()
        control.enter()
        log.event(tick, clock.now(), "paused")
        log.flush()
        announce(True)
        while control.must_wait() and not self.interrupts.requested:
            wake.wait(POLL_S)
            wake.clear()
            if keys is not None:
                self.read_keys(keys)
            show()
        stepping = control.leave()
        self.pacer.release()
        if not self.interrupts.requested:
            log.event(tick, clock.now(), "step" if stepping else "resumed")
            announce(False)
