"""The determinism handshake between an emulator and its in-process driver.

On a virtual clock the runtime calls ``emulator.step(now)`` once per tick. The
bytes still travel through the pseudo-terminal exactly as on a USB port; this
barrier only tells the emulator *when* the driver has caught up, so that when
``step`` returns the driver has read and handled every byte the emulator sent,
has handled the tick's time, and the emulator has read every byte the driver
wrote. Nothing then depends on thread scheduling, and two runs with the same
seed exchange the same bytes at the same virtual times.

Counters are in bytes since :meth:`StepBarrier.attach`:

* ``sent`` / ``consumed``: written by the emulator / read *and handled* by the driver;
* ``written`` / ``received``: written by the driver / read by the emulator.

A driver without a barrier (real hardware, an external client of
``armtree emulate``) simply never attaches, and the emulator never waits.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable


class StepBarrier:
    """Handshake state shared by one emulator and at most one driver (thread-safe).

    ``timeout`` (wall seconds) bounds every wait, so a hung driver slows a run
    down instead of dead-locking it.
    """

    def __init__(self, timeout: float = 2.0) -> None:
        self.timeout = timeout
        self._cond = threading.Condition()
        self._attached = False
        self._wake: Callable[[], None] | None = None
        self._tick = -math.inf
        self._driver_time = -math.inf
        self._sent = 0
        self._consumed = 0
        self._written = 0
        self._received = 0

    # -- driver side -------------------------------------------------------

    def attach(self, wake: Callable[[], None] | None = None) -> None:
        """A driver opened the port: counting starts from zero.

        ``wake`` is called (from the emulator's thread) when a new tick begins,
        so a driver blocked in a read can handle the new time at once.
        """
        with self._cond:
            self._attached = True
            self._wake = wake
            self._driver_time = -math.inf
            self._sent = self._consumed = self._written = self._received = 0
            self._cond.notify_all()

    def detach(self) -> None:
        """The driver closed the port or lost the link: the emulator stops waiting."""
        with self._cond:
            self._attached = False
            self._wake = None
            self._cond.notify_all()

    @property
    def attached(self) -> bool:
        """True while a driver takes part in the handshake."""
        with self._cond:
            return self._attached

    @property
    def tick(self) -> float:
        """The newest tick time the emulator announced (seconds, ``-inf`` before the first)."""
        with self._cond:
            return self._tick

    def wrote(self, n: int) -> None:
        """Driver side: ``n`` bytes were written to the port (call right after the write)."""
        # No wake-up: the emulator waits only for what the driver handled, and reads
        # what it wrote once it has caught up.
        with self._cond:
            self._written += n

    def handled(self, n_read: int, time_handled: float) -> None:
        """Driver side: ``n_read`` more bytes were read and fully handled (replies
        written), and every action due at ``time_handled`` has been taken."""
        with self._cond:
            progress = n_read > 0 or time_handled > self._driver_time
            self._consumed += n_read
            self._driver_time = max(self._driver_time, time_handled)
            # Wake the emulator only when it may have caught up: a part of a reply, or a
            # read that timed out with nothing new, would only send it back to sleep,
            # at the cost of a thread switch each way.
            if progress and self._consumed >= self._sent:
                self._cond.notify_all()

    # -- emulator side -----------------------------------------------------

    def begin(self, now: float) -> None:
        """Emulator side: announce tick ``now`` and wake the driver."""
        with self._cond:
            self._tick = max(self._tick, now)
            wake = self._wake if self._attached else None
        if wake is not None:
            wake()

    def sent(self, n: int) -> None:
        """Emulator side: ``n`` bytes were written to the driver."""
        with self._cond:
            self._sent += n

    def received(self, n: int) -> None:
        """Emulator side: ``n`` bytes from the driver were read."""
        with self._cond:
            self._received += n

    def missing(self) -> int:
        """Bytes the driver wrote that the emulator has not read yet (0 when detached)."""
        with self._cond:
            return max(0, self._written - self._received) if self._attached else 0

    def wait_driver(self, tick: float | None = None) -> bool:
        """Block until the driver handled every byte sent (and tick ``tick`` when given).

        Returns False at once when no driver is attached, and after
        :attr:`timeout` wall seconds if the driver does not catch up.
        """

        def caught_up() -> bool:
            if not self._attached:
                return True
            if self._consumed < self._sent:
                return False
            return tick is None or self._driver_time >= tick

        with self._cond:
            ok = self._cond.wait_for(caught_up, timeout=self.timeout)
            return ok and self._attached
