"""The console scripts' entry points: Ctrl-C, SIGTERM, SIGHUP and SIGQUIT handled from the first moment.

``run-tree`` and ``armtree`` start here. Importing this module takes the signals
over before anything heavy is imported, so an interrupt while the program is still
starting (nothing has moved yet) exits 130 with one line instead of a traceback.
Once the command line is ready, an interrupt becomes ``KeyboardInterrupt``, which
the CLI turns into exit 130 after its clean-up; a run installs its own safe-stop
handlers (:mod:`armtree.runtime.interrupts`). An interrupt while the process exits, after
the command returned, ends it with the command's code at once.
"""

from __future__ import annotations

# The C module: ``signal`` imports enum, which alone takes long enough to be interrupted.
import _signal
import contextlib
import os
import sys

# Cheap this early: it only names what _collections_abc, which os loads, defines.
from collections.abc import Callable

EXIT_INTERRUPTED = 130
#: armtree.runtime.interrupts.STOP_SIGNALS, without importing it (nor enum) this early.
_STOP_SIGNALS = (_signal.SIGINT, _signal.SIGTERM, _signal.SIGHUP, _signal.SIGQUIT)


def _exit_starting(signum: int, frame: object) -> None:
    # Nothing has been opened or moved yet: say so and leave without unwinding imports.
    try:
        os.write(2, b"interrupted while starting\n")
    finally:
        os._exit(EXIT_INTERRUPTED)


def _take_signals(handler: Callable[[int, object], None]) -> None:
    for sig in _STOP_SIGNALS:
        try:
            _signal.signal(sig, handler)
        except (ValueError, OSError):  # noqa: SIM105 - contextlib costs an import here
            continue


_take_signals(_exit_starting)


def _exit_interrupted(signum: int, frame: object) -> None:
    os._exit(EXIT_INTERRUPTED)


def _raise_interrupt(signum: int, frame: object) -> None:
    # One KeyboardInterrupt unwinds the command and its clean-up; a second one raised
    # inside that unwinding (or after the command returned) would escape every handler.
    _take_signals(_exit_interrupted)
    raise KeyboardInterrupt


def _ignore_signals() -> None:
    # Python's shutdown puts its own handlers back to the default, under which a late
    # signal kills the process by the signal instead of leaving with the command's code.
    for sig in _STOP_SIGNALS:
        try:
            _signal.signal(sig, _signal.SIG_IGN)
        except (ValueError, OSError):  # noqa: SIM105 - as in _take_signals
            continue


def _entry(command: str) -> int:
    from . import commandline as cli

    _take_signals(_raise_interrupt)
    try:
        code = cli.run_tree_main() if command == "run-tree" else cli.main()
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        code = EXIT_INTERRUPTED
    except SystemExit as exc:  # argparse's --help and usage errors
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    final = int(code)
    if final != EXIT_INTERRUPTED and _signal.getsignal(_signal.SIGINT) is _exit_interrupted:
        # The interrupt surfaced as another error (an extension module's import turns it
        # into ImportError); the user still asked to stop.
        print("interrupted", file=sys.stderr)
        final = EXIT_INTERRUPTED

    def _exit_finished(signum: int, frame: object) -> None:
        # The command had finished (its result written and shown): it keeps its code.
        with contextlib.suppress(OSError):
            os.write(2, f"signal after the command had ended: exit {final} kept\n".encode())
        os._exit(final)

    _take_signals(_exit_finished)
    import atexit

    atexit.register(_ignore_signals)
    return final


def run_tree() -> int:
    """``run-tree``: see :func:`armtree.cli.commandline.run_tree_main`."""
    return _entry("run-tree")


def armtree() -> int:
    """``armtree``: see :func:`armtree.cli.commandline.main`."""
    return _entry("armtree")


if __name__ == "__main__":
    sys.exit(armtree())
