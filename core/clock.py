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
    """Monotonic wall time, for --realtime and real hardware."""

    def __init__(self) -> None:
        self._t0 = time.monotonic()

    def now(self) -> float:
        """Seconds since this clock was made."""
        return time.monotonic() - self._t0

    def sleep_until(self, t: float) -> None:
        """Sleep the calling thread until ``now() >= t``."""
        delay = t - self.now()
        if delay > 0:
            time.sleep(delay)
