"""Clocks a run can be driven by: virtual time for simulation, wall time for hardware.

Every component that needs the time (timers, timeouts, emulators, the camera
renderer) reads it from the run's clock, never from :mod:`time` directly, so a
simulated run is deterministic and runs as fast as the machine allows.
Times are in seconds.
"""

from __future__ import annotations

import threading
import time
from abc import ABC, abstractmethod


class Clock(ABC):
    """The time source of one run, in seconds since the run began."""

    #: ``True`` for a clock that only moves when the runtime advances it.
    virtual: bool = False

    @abstractmethod
    def now(self) -> float:
        """Seconds since the run began."""

    @abstractmethod
    def sleep_until(self, t: float) -> None:
        """Block until ``now() >= t`` (a virtual clock jumps there at once)."""

    def hold(self) -> None:  # noqa: B027 - a virtual clock stands still by itself
        """Stop the clock (a paused run): ``now()`` stays where it is until :meth:`release`."""

    def release(self) -> None:  # noqa: B027
        """Let a held clock run on from where it stood."""


class VirtualClock(Clock):
    """A clock that jumps forward when the runtime tells it to; thread-safe to read."""

    virtual = True

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)
        self._lock = threading.Lock()

    def now(self) -> float:
        """Current virtual time in seconds."""
        with self._lock:
            return self._t

    def advance(self, dt: float) -> float:
        """Move forward by ``dt`` seconds (``dt >= 0``) and return the new time."""
        if dt < 0:
            raise ValueError(f"a virtual clock cannot go back (dt={dt})")
        with self._lock:
            self._t += dt
            return self._t

    def sleep_until(self, t: float) -> None:
        """Jump to ``t`` if it is in the future."""
        with self._lock:
            self._t = max(self._t, float(t))


class WallClock(Clock):
    """Monotonic wall time, for --realtime and real hardware, less the time it was held."""

    def __init__(self) -> None:
        # (start, held since): replaced as one tuple, so readers on other threads
        # never see a start that does not belong to the hold.
        self._state: tuple[float, float | None] = (time.monotonic(), None)

    def now(self) -> float:
        """Seconds since this clock was made, not counting time it was held."""
        t0, held = self._state
        return (held if held is not None else time.monotonic()) - t0

    def hold(self) -> None:
        """Stand still until :meth:`release`."""
        t0, held = self._state
        if held is None:
            self._state = (t0, time.monotonic())

    def release(self) -> None:
        """Run on from where the clock stood: the held time is skipped."""
        t0, held = self._state
        if held is not None:
            self._state = (t0 + time.monotonic() - held, None)

    def sleep_until(self, t: float) -> None:
        """Sleep the calling thread until ``now() >= t``."""
        delay = t - self.now()
        if delay > 0:
            time.sleep(delay)
