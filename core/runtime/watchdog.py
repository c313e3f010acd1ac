"""The tick watchdog: a tick that does not return is a fault, not a hang.

A :class:`TickWatchdog` runs on its own thread and watches the run's ticks on
the wall clock, whatever clock the run itself uses. The tick loop marks each
tick's start and end (two attribute writes). Two things make the watchdog act:

* a tick (a component step or the tree's tick) that runs longer than the
  limit (``watchdog: {tick_s: ...}`` in the profile): a hardware-class fault
  naming the node that was running, exit 3;
* an interrupt (Ctrl-C, SIGTERM, a lost link) that the tick loop has not taken
  up after a short grace because the tick it waits for never ends: the first
  interrupt always starts the safe stop.

Acting means: tell the arm to stop through its driver's own thread (the run's
thread is the one that is stuck), then *abandon* the tick by raising
:class:`TickAbandoned` in the run's thread, so the runtime halts the tree, keeps
a held object, flushes the log and exits with the cause's code. A run that owns
the process (the command line) and still has not finished some seconds later is
ended from here, after a best-effort flush, with the same code.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from types import FrameType
from typing import Any

#: How long an interrupt may wait for a tick to end before the tick is abandoned, wall s.
INTERRUPT_GRACE_S = 0.25
#: How often the watchdog looks, wall seconds.
POLL_S = 0.02


class TickAbandoned(BaseException):
    """Raised in the run's thread to leave a tick that does not return.

    A ``BaseException``, so that a behaviour's ``except Exception`` does not
    swallow it. ``reason`` says why (``"watchdog"`` or the interrupt's reason).
    """

    def __init__(self, reason: str = "watchdog") -> None:
        super().__init__(reason)
        self.reason = reason


class TickWatchdog:
    """Watches the ticks of one run from a daemon thread; see the module docstring.

    ``limit_s`` is the longest a tick may take (wall seconds). ``pending()``
    returns the reason of an interrupt the run has not taken up (or ``None``).
    ``on_overrun(message)`` is called (on the watchdog thread) when a tick
    overruns; ``stop_arm()`` tells the arm to stop without blocking.
    ``use_signal``: abandon the tick with a signal to the main thread (which
    also breaks a blocking system call) rather than an asynchronous exception.
    """

    def __init__(
        self,
        limit_s: float,
        *,
        pending: Callable[[], str | None],
        on_overrun: Callable[[str], None],
        stop_arm: Callable[[], None],
        describe: Callable[[FrameType | None], str],
        use_signal: bool = False,
    ) -> None:
        self.limit_s = float(limit_s)
        self._pending = pending
        self._on_overrun = on_overrun
        self._stop_arm = stop_arm
        self._describe = describe
        self._use_signal = use_signal
        self._thread: threading.Thread | None = None
        self._target = threading.get_ident()
        self._done = threading.Event()
        #: Wall time (``time.monotonic``) the current tick started, None between ticks.
        self.tick_started: float | None = None
        #: What the current tick is doing ("component step" or "tree tick").
        self.phase = ""
        #: Set once a tick was abandoned: the reason, until the run takes it.
        self.abandoning: str | None = None
        #: True once the watchdog abandoned a tick (the run's thread may be unreliable).
        self.fired = False
        #: Where the abandoned tick was stuck: a node's path and position, or code.
        self.stuck_in = ""
        self._interrupt_seen: float | None = None

    # ----------------------------------------------------------------- run side

    def start(self) -> None:
        """Start watching the calling thread's ticks."""
        self._target = threading.get_ident()
        self._thread = threading.Thread(target=self._watch, name="tick watchdog", daemon=True)
        self._thread.start()

    def begin(self, phase: str) -> None:
        """The run's thread starts a step of a tick (cheap: two assignments and a clock read)."""
        self.phase = phase
        self.tick_started = time.monotonic()

    def end(self) -> None:
        """The run's thread finished the tick."""
        self.tick_started = None

    def claim_signal(self) -> bool:
        """In the SIGINT handler: True when the signal is the watchdog's own.

        Raises :class:`TickAbandoned` when the tick it was sent to leave is still
        running; a tick that ended meanwhile needs nothing more.
        """
        reason, self.abandoning = self.abandoning, None
        if reason is None:
            return False
        if self.tick_started is not None:
            raise TickAbandoned(reason)
        return True

    def close(self) -> None:
        """Stop watching ticks (the run's thread has left its loop; call it from there)."""
        self.tick_started = None
        self._done.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
        if self.fired and not self._use_signal:
            # An exception aimed at a tick that had just ended must not land later.
            ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(self._target), None)

    # ------------------------------------------------------------ watchdog side

    def _watch(self) -> None:
        while not self._done.wait(POLL_S):
            started = self.tick_started
            if started is None or self.fired:
                self._interrupt_seen = None
                continue
            now = time.monotonic()
            reason = self._pending()
            if reason is not None:
                if self._interrupt_seen is None:
                    self._interrupt_seen = now
                if now - max(self._interrupt_seen, started) >= INTERRUPT_GRACE_S:
                    self._where()
                    self._abandon(reason)
                continue
            if now - started > self.limit_s:
                message = (
                    f"a tick ran longer than the watchdog's {self.limit_s:g} s "
                    f"({self.phase}) in {self._where()}"
                )
                self._on_overrun(message)
                self._abandon("watchdog")

    def _where(self) -> str:
        """Describe where the run's thread is stuck (and record it in :attr:`stuck_in`)."""
        self.stuck_in = self._describe(sys._current_frames().get(self._target))
        return self.stuck_in

    def _abandon(self, reason: str) -> None:
        self.fired = True
        with contextlib.suppress(Exception):
            self._stop_arm()
        self.abandoning = reason
        if self._use_signal:
            # The handler raises TickAbandoned in the main thread, also out of a sleep
            # or a blocking read that an asynchronous exception would not reach.
            with contextlib.suppress(Exception):
                signal.pthread_kill(self._target, signal.SIGINT)
        else:
            ctypes.pythonapi.PyThreadState_SetAsyncExc(
                ctypes.c_ulong(self._target), ctypes.py_object(TickAbandoned)
            )


def force_exit_later(
    seconds: float, code: int, last_words: Callable[[], None], done: threading.Event
) -> threading.Thread:
    """Exit the process with ``code`` after ``seconds`` unless ``done`` is set first.

    For a run that owns the process and whose stop may itself be stuck:
    ``last_words()`` flushes what can be flushed before ``os._exit``.
    """

    def wait() -> None:
        if done.wait(seconds):
            return
        with contextlib.suppress(Exception):
            last_words()
        with contextlib.suppress(Exception):
            sys.stderr.write(f"\nthe stop did not finish within {seconds:g} s: exit {code}\n")
            sys.stderr.flush()
        os._exit(code)

    thread = threading.Thread(target=wait, name="stop deadline", daemon=True)
    thread.start()
    return thread


def running_behaviour(frame: FrameType | None, known: Callable[[Any], bool]) -> Any:
    """The deepest object on ``frame``'s stack that ``known`` accepts as a behaviour."""
    found = None
    while frame is not None:
        candidate = frame.f_locals.get("self")
        if candidate is not None and known(candidate):
            found = candidate
            break
        frame = frame.f_back
    return found


def innermost_code(frame: FrameType | None) -> str:
    """``module.function`` of the innermost frame, for a report of a stuck component."""
    if frame is None:
        return "an unknown place"
    code = frame.f_code
    module = frame.f_globals.get("__name__", "?")
    return f"{module}.{getattr(code, 'co_qualname', code.co_name)}"
