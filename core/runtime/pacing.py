"""When a run's next tick starts: on schedule on the run clock, kept to a wall-clock speed
on request, counting the ticks that start late, and the clock held while a run pauses."""

from __future__ import annotations

import threading
import time

from armtree.api.clock import Clock


class Pacer:
    """The schedule of one run's ticks: tick ``k`` starts ``k`` periods after the first.

    On a virtual clock :meth:`advance` jumps the clock to the next tick (and, with
    a speed, waits for the wall clock to catch up: :meth:`pace`); on a wall clock
    it waits until the next tick is due, woken at once by ``wake`` (an interrupt).
    A tick that starts late counts in :attr:`overruns`; on a wall clock how late
    each tick started is kept in :attr:`lateness` (seconds).
    """

    def __init__(self, clock: Clock, period: float, wake: threading.Event) -> None:
        self._clock = clock
        self._period = period
        self._wake = wake
        self._virtual = clock.virtual
        self._t0 = self._next = 0.0
        # (wall time, run time, speed) that speed pacing counts from.
        self._anchor: tuple[float, float, float] | None = None
        #: Ticks that started late: past their period on a wall clock, behind speed on a virtual one.
        self.overruns = 0
        #: On a wall clock, how late each tick started against its schedule (seconds).
        self.lateness: list[float] = []

    def start(self) -> None:
        """The first tick is due now."""
        self._t0 = self._next = self._clock.now()

    def began(self, now: float) -> None:
        """A tick started at run time ``now`` (on a wall clock, its lateness is kept)."""
        if not self._virtual:
            self.lateness.append(now - self._next)

    def advance(self, ticks: int, speed: float | None) -> None:
        """Wait for tick ``ticks + 1``: jump a virtual clock to it (at ``speed`` run s per
        wall s if set), or wait for it on a wall clock."""
        clock = self._clock
        if self._virtual:
            # Multiplying (not summing) keeps times exact-ish, and rounding to a
            # nanosecond keeps logs free of float noise.
            self._next = round(self._t0 + ticks * self._period, 9)
            clock.sleep_until(self._next)
            if speed is not None:
                self.pace(self._next, speed)
            return
        self._next += self._period
        late = clock.now() - self._next
        if late > 0:
            # The tick took longer than its period: count it and start the next
            # one now rather than bunching ticks to catch up.
            self.overruns += 1
            self._next = clock.now()
        else:
            self._wake.wait(-late)

    def pace(self, t: float, speed: float) -> None:
        """On a virtual clock, wait until run time ``t`` is due at ``speed`` run s per wall s."""
        wall = time.monotonic()
        anchor = self._anchor
        if anchor is None or anchor[2] != speed:
            self._anchor = (wall, t, speed)
            return
        delay = anchor[0] + (t - anchor[1]) / speed - wall
        if delay > 0:
            self._wake.wait(delay)
        else:
            # Behind: count it, and start again from now rather than bunching ticks.
            self.overruns += 1
            self._anchor = (wall, t, speed)

    def hold(self) -> None:
        """Hold the run clock (a pause)."""
        self._clock.hold()

    def release(self) -> None:
        """Let the run clock go on after :meth:`hold`; speed pacing starts afresh."""
        self._clock.release()
        self._anchor = None
