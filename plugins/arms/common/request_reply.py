"""Emulator base for request/reply firmware (Magician, Marlin, SSC-32): a fully settled step.

:meth:`PtyEmulator.step` first handles the bytes the host wrote since the last
step, at the previous time. With a request/reply protocol the host answers a
reply at once with its next request, and whether that request is read in the
same first pass (at the previous time) or later (at the next event or tick)
would depend on thread timing. Settling with the driver right after the first
pass makes every exchange triggered by those bytes happen at the previous time,
so two runs with the same seed log the same bytes at the same times.
"""

from __future__ import annotations

from .pty_emulator import PtyEmulator


class RequestReplyEmulator(PtyEmulator):
    """A :class:`PtyEmulator` whose step settles the host's follow-up requests before time moves."""

    def step(self, now: float) -> None:
        """Handle received bytes and every follow-up at the previous time, then step to ``now``."""
        with self._lock:
            if self._master is not None:
                self._pump_input(complete=True)
                self._settle(None)
        super().step(now)
