"""Interrupt sources of a run: SIGINT, SIGTERM, SIGHUP, SIGQUIT, the stop key and component events.

All of them end in :meth:`Interrupts.request`, which only records the reason and
wakes the tick loop; the runtime halts the tree at the start of its next tick
(so within one tick). A signal that arrives while a run is already stopping
forces the process out at once (after a best-effort flush of the run log), so
a second Ctrl-C never hangs. A first interrupt during a tick that does not return
is taken up by the run's tick watchdog (:mod:`armtree.runtime.watchdog`), which leaves
the tick so that the safe stop starts anyway.
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any, TextIO

from armtree.errors import HardwareFault

#: Exit code of an interrupted run (128 + SIGINT, as shells report it).
EXIT_INTERRUPTED = 130
#: The signals that stop a run safely: Ctrl-C, a kill, a closed terminal (SIGHUP, a
#: common way runs end) and Ctrl-\ (SIGQUIT), each with a result record in the run log.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT)


class Interrupts:
    """The first interrupt request of a run, from any thread; later ones are ignored.

    ``force_exit`` is called (from the signal handler) when a signal arrives
    while the run is already being interrupted or stopped; by default it exits
    the process with status 130 without running further Python clean-up.
    """

    def __init__(self, force_exit: Callable[[], None] | None = None) -> None:
        self.reason: str | None = None
        self.fault: HardwareFault | None = None
        self.stopping = False
        #: The run's :class:`~armtree.runtime.watchdog.TickWatchdog`, whose own SIGINT leaves a stuck tick.
        self.watchdog: Any = None
        self.wake = threading.Event()
        self._lock = threading.Lock()
        self._force_exit = force_exit or _exit_now

    @property
    def requested(self) -> bool:
        """True once anything asked the run to stop."""
        return self.reason is not None

    def request(self, reason: str, fault: HardwareFault | None = None) -> bool:
        """Ask the run to halt for ``reason``; True if this was the first request."""
        with self._lock:
            if self.reason is not None:
                return False
            self.reason = reason
            self.fault = fault
        self.wake.set()
        return True

    def _on_signal(self, signum: int, frame: object) -> None:
        watchdog = self.watchdog
        if watchdog is not None and signum == signal.SIGINT and watchdog.claim_signal():
            return
        name = signal.Signals(signum).name
        if self.requested or self.stopping:
            self._force_exit()
            return
        # No lock and no Event.set() here: the handler runs on the main thread, which may
        # be inside request() or a pacing Event.wait() holding that very lock (a second
        # Ctrl-C then hung the process). The tick loop reads ``reason`` at its next tick,
        # and a pacing wait on the main thread ends within its tick period anyway.
        self.reason = name

    @contextlib.contextmanager
    def signals(self, enabled: bool = True) -> Iterator[bool]:
        """Route the :data:`STOP_SIGNALS` here while the block runs (main thread only).

        Yields whether the handlers were installed; the previous handlers are
        restored on exit.
        """
        if not enabled or threading.current_thread() is not threading.main_thread():
            yield False
            return
        previous = {}
        for sig in STOP_SIGNALS:
            previous[sig] = signal.getsignal(sig)
            signal.signal(sig, self._on_signal)
        try:
            yield True
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)


def _exit_now() -> None:
    with contextlib.suppress(Exception):
        sys.stderr.write("\nforced exit: interrupted again while stopping\n")
        sys.stderr.flush()
    os._exit(EXIT_INTERRUPTED)


class StopKey:
    """The stop key (``q``), and the other run keys, read without blocking from a terminal on stdin.

    Active only when ``stream`` is a TTY; inside the ``with`` block the terminal
    is in cbreak mode (keys arrive without Enter, Ctrl-C still signals) and it is
    restored on exit, whatever happens.
    """

    def __init__(self, stream: TextIO | None = None, key: str = "q") -> None:
        self.stream = stream if stream is not None else sys.stdin
        self.key = key.encode()
        self.active = False
        self._fd: int | None = None
        self._saved: list | None = None

    def __enter__(self) -> StopKey:
        try:
            if self.stream is None or not self.stream.isatty():
                return self
            import termios
            import tty

            self._fd = self.stream.fileno()
            self._saved = termios.tcgetattr(self._fd)
            tty.setcbreak(self._fd)
            self.active = True
        except (OSError, ValueError, ImportError, AttributeError):
            self.active = False
        return self

    def pressed(self) -> bool:
        """True if the stop key was typed since the last call; never blocks."""
        return self.key.decode() in self.read()

    def read(self) -> str:
        """Every key typed since the last call, lower-cased (``""`` if none); never blocks."""
        if not self.active or self._fd is None:
            return ""
        try:
            ready, _, _ = select.select([self._fd], [], [], 0)
            if not ready:
                return ""
            return os.read(self._fd, 64).decode("utf-8", "replace").lower()
        except OSError:
            return ""

    def restore(self) -> None:
        """Put the terminal back as it was (idempotent)."""
        if self.active and self._fd is not None and self._saved is not None:
            import termios

            with contextlib.suppress(OSError):
                termios.tcsetattr(self._fd, termios.TCSADRAIN, self._saved)
        self.active = False

    def __exit__(self, *exc: object) -> None:
        self.restore()
