"""Pause, step one tick, resume, stop and pace a run, from any thread.

A :class:`RunControl` belongs to one :class:`~armtree.runtime.runner.Run` (``run.control``).
The terminal keys, the monitor page and tests all drive it; the tick loop reads
it between ticks, so nothing happens in the middle of a tick:

* ``pause()``: the run holds at the next safe point, a tick boundary where the
  arm has no command under way (on a virtual clock every tick boundary is one:
  nothing the runtime steps moves while the clock stands). While held the run's
  clock stands still, running behaviours keep their resources and nothing is
  halted.
* ``step()``: while held, run exactly one more tick, then hold again at the next
  safe point; while running, the same as ``pause()``.
* ``resume()``: go on ticking.
* ``stop()``: the same safe stop as Ctrl-C (the run ends INTERRUPTED, exit 130).
* ``speed``: on a virtual clock, run seconds per wall second (``1.0`` real
  time, ``None`` as fast as the machine allows); wall clocks ignore it.

Every request is idempotent and returns at once; :attr:`state` says what the
loop is doing about it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from .interrupts import Interrupts

#: Terminal keys and what they do (typed without Enter while a run shows its view).
KEYS: dict[str, str] = {"p": "pause", " ": "pause", "n": "step", "r": "resume", "q": "stop"}

RUNNING, PAUSING, PAUSED = "running", "pausing", "paused"


class RunControl:
    """Requests to pause, step, resume or stop one run, and the state the loop is in.

    ``interrupts`` is the run's :class:`~armtree.runtime.interrupts.Interrupts`: a stop
    is an interrupt request. Every other request sets :attr:`wake`, which a held
    loop waits on.
    ``on_change(state)`` listeners are called (on the caller's or the loop's
    thread) whenever :attr:`state` changes.
    """

    def __init__(self, interrupts: Interrupts) -> None:
        self.interrupts = interrupts
        self._lock = threading.Lock()
        self._hold = False
        self._steps = 0
        self._paused = False
        self._speed: float | None = None
        #: Set on every request; the held loop waits on it.
        self.wake = threading.Event()
        self.listeners: list[Callable[[str], None]] = []

    # ------------------------------------------------------------------
    # Requests (any thread)
    # ------------------------------------------------------------------

    def pause(self) -> None:
        """Hold the run at the next safe point."""
        with self._lock:
            self._hold, self._steps = True, 0
        self._changed()

    def resume(self) -> None:
        """Go on ticking (cancels a pause not yet reached)."""
        with self._lock:
            self._hold, self._steps = False, 0
        self._changed()

    def toggle(self) -> None:
        """Pause a running run, resume a paused (or pausing) one."""
        if self.holding:
            self.resume()
        else:
            self.pause()

    def step(self) -> None:
        """While held, run one more tick and hold again; otherwise pause."""
        with self._lock:
            if self._hold and self._paused:
                self._steps += 1
            self._hold = True
        self._changed()

    def stop(self, source: str = "stop") -> None:
        """End the run as Ctrl-C does (INTERRUPTED, exit 130); ``source`` is the reason logged."""
        self.interrupts.request(source)

    def key(self, typed: str) -> None:
        """Act on keys typed in the terminal (:data:`KEYS`; ``q`` is handled as a stop)."""
        for char in typed.lower():
            action = KEYS.get(char)
            if action == "pause":
                self.toggle()
            elif action == "step":
                self.step()
            elif action == "resume":
                self.resume()
            elif action == "stop":
                self.stop("stop key")

    @property
    def speed(self) -> float | None:
        """Run seconds per wall second on a virtual clock; ``None``: as fast as possible."""
        return self._speed

    @speed.setter
    def speed(self, value: float | None) -> None:
        if value is not None and not value > 0:
            raise ValueError(f"speed must be positive (got {value!r}) or None")
        self._speed = None if value is None else float(value)
        self._changed()

    # ------------------------------------------------------------------
    # What the loop sees
    # ------------------------------------------------------------------

    @property
    def holding(self) -> bool:
        """True while a pause is asked for (reached or not)."""
        return self._hold

    @property
    def paused(self) -> bool:
        """True while the loop is actually held."""
        return self._paused

    @property
    def state(self) -> str:
        """``"running"``, ``"pausing"`` (asked for, or a step under way: held again at the
        next safe point) or ``"paused"``."""
        with self._lock:
            if not self._hold:
                return RUNNING
            return PAUSED if self._paused and not self._steps else PAUSING

    def must_wait(self) -> bool:
        """Loop side: True while held with no step granted."""
        with self._lock:
            return self._hold and not self._steps

    def enter(self) -> None:
        """Loop side: the run is now held."""
        with self._lock:
            self._paused = True
        self._changed()

    def leave(self) -> bool:
        """Loop side: the run ticks again; True if it leaves for one granted step."""
        with self._lock:
            self._paused = False
            stepping = self._hold and self._steps > 0
            if stepping:
                self._steps -= 1
        self._changed()
        return stepping

    def _changed(self) -> None:
        self.wake.set()
        state = self.state
        for listener in list(self.listeners):
            listener(state)


__all__ = ["KEYS", "PAUSED", "PAUSING", "RUNNING", "RunControl"]
