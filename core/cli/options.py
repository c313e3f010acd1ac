"""What every command line shares: exit codes, the plugin and seed options, and the
guard that turns every error into its message and exit code.

Exit codes everywhere: 0 success, 1 the tree ended in FAILURE (or an unexpected
error), 2 usage or invalid input (every :class:`ConfigError` printed as
``FILE:LINE:COL: message``), 3 hardware fault, 130 interrupted. No raw traceback
reaches the user unless ``--debug`` is given. This module loads no plugin and none of
numpy, OpenCV or py_trees, so ``--version`` and a usage error answer at once.
"""

from __future__ import annotations

import argparse
import errno
import sys
import traceback
from collections.abc import Callable, Sequence
from typing import Any

from armtree.errors import ConfigError, HardwareFault
from armtree.runtime.interrupts import EXIT_INTERRUPTED

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_USAGE = 2
EXIT_HARDWARE = 3

#: What marks a --record folder as holding a run: the run log, and what armtree's own
#: plugins record next to it (monitor, sim); --overwrite removes them.
RUN_FILES = (
    "run.jsonl",
    "run.mcap",
    "score.json",
    "camera.mp4",
    "overhead.mp4",
    "overhead.png",
)
#: The lock a run holds on its --record folder while it writes there.
RUN_LOCK = ".armtree-run.lock"


def plugin_options(parser: argparse.ArgumentParser, suppress: bool = False) -> None:
    """Add ``--plugin``, ``-p no:NAME`` and ``--debug`` to ``parser``."""
    default: Any = argparse.SUPPRESS if suppress else None
    parser.add_argument(
        "--plugin",
        action="append",
        metavar="MODULE_OR_FILE",
        default=default,
        help="load a plugin module or .py file (repeatable)",
    )
    parser.add_argument(
        "-p",
        dest="block",
        action="append",
        metavar="no:NAME",
        default=default,
        help="block a plugin by name, as -p no:NAME (repeatable)",
    )
    parser.add_argument(
        "--debug",
        action="store_true",
        default=argparse.SUPPRESS if suppress else False,
        help="show tracebacks",
    )


def version_text(prog: str) -> str:
    """``PROG VERSION`` of the installed armtree, as ``--version`` prints it."""
    from armtree.hooks.plugin_checks import installed_version

    return f"{prog} {installed_version()}"


def add_version_option(parser: argparse.ArgumentParser, prog: str) -> None:
    """Add ``--version``: print the installed armtree's version and exit 0."""
    parser.add_argument("--version", action="version", version=version_text(prog))


def add_set_option(parser: argparse.ArgumentParser, help: str) -> None:  # noqa: A002
    """Add the repeatable ``--set KEY=VALUE`` option (collected in ``args.overrides``)."""
    parser.add_argument(
        "--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE", help=help
    )


def seed_value(text: str) -> int:
    """An argparse ``type`` for ``--seed``: an integer >= 0 (numpy's generators take no
    negative seed); anything else is a usage error, exit 2."""
    try:
        seed = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a seed: give an integer >= 0") from None
    if seed < 0:
        raise argparse.ArgumentTypeError(f"{seed} is not a seed: give an integer >= 0")
    return seed


def add_tree_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``TREE``, ``--rig PROFILE`` and ``--set KEY=VALUE`` as ``armtree check`` takes them."""
    parser.add_argument("tree", metavar="TREE", help="tree file or name of a shipped tree")
    parser.add_argument("--rig", metavar="PROFILE", help="hardware profile (default: the tree's)")
    add_set_option(
        parser, "override a profile value (arm.port=/dev/ttyUSB0) or set a blackboard value"
    )


def blocked_names(values: Sequence[str] | None) -> list[str]:
    """The plugin names of ``-p no:NAME`` options; anything else is a usage error."""
    names = []
    for value in values or ():
        if not value.startswith("no:") or len(value) <= 3:
            raise ConfigError(f"-p {value}: write -p no:NAME to block the plugin NAME")
        names.append(value[3:])
    return names


#: The errors of a disk that filled up (or a file-size limit) while writing.
DISK_FULL = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})
#: What to do about it.
DISK_FULL_ADVICE = "the record is incomplete; free some space or write to another disk"


def guarded(action: Callable[[], int], debug: bool) -> int:
    """Run ``action`` and turn every error into its message and exit code."""
    try:
        return action()
    except ConfigError as exc:
        raised = [e.traceback for e in exc.errors if e.traceback]
        if debug:
            for text in raised:
                print(text, file=sys.stderr, end="")
        print(exc.format(), file=sys.stderr)
        if raised and not debug:
            print("(run again with --debug for the traceback)", file=sys.stderr)
        return EXIT_USAGE
    except HardwareFault as exc:
        if debug:
            traceback.print_exc()
        print(f"hardware fault: {exc}", file=sys.stderr)
        return EXIT_HARDWARE
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except OSError as exc:
        if exc.filename is None:
            return _unexpected(exc, debug)
        # A path the user gave that cannot be read or written (-o, --record, --out).
        if debug:
            traceback.print_exc()
        advice = (
            DISK_FULL_ADVICE
            if exc.errno in DISK_FULL
            else "give a path that exists and you may use"
        )
        print(f"{exc.filename}: {exc.strerror or exc}; {advice}", file=sys.stderr)
        return EXIT_USAGE
    except Exception as exc:  # noqa: BLE001 - the user gets a line, --debug the traceback
        return _unexpected(exc, debug)


def _unexpected(exc: Exception, debug: bool) -> int:
    """An error armtree did not foresee: one line, the traceback with ``debug``; exit 1."""
    if debug:
        traceback.print_exc()
        print(f"error: {type(exc).__name__}: {exc}", file=sys.stderr)
    else:
        print(
            f"error: {type(exc).__name__}: {exc} (run again with --debug for the traceback)",
            file=sys.stderr,
        )
    return EXIT_FAILURE
