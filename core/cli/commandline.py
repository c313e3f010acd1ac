"""The command lines: ``run-tree TREE ...`` and ``armtree SUBCOMMAND ...``.

``armtree`` dispatches to every command registered through the
``armtree_commands`` hook, plus its own ``run`` (the same as ``run-tree``) and
``bench``. Exit codes everywhere: 0 success, 1 the tree ended in FAILURE (or an
unexpected error), 2 usage or invalid input (every :class:`ConfigError` printed
as ``FILE:LINE:COL: message``), 3 hardware fault, 130 interrupted. No raw
traceback reaches the user unless ``--debug`` is given.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
import sys
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path
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

#: Commands the CLI provides itself; a plugin may not register these names.
OWN_COMMANDS = ("run", "bench")


# ---------------------------------------------------------------------------
# Shared options and error handling
# ---------------------------------------------------------------------------


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


def plugin_manager_for(plugins: Sequence[str] | None, block: Sequence[str] | None) -> Any:
    """The plugin manager for these command-line options (shared per process)."""
    from armtree.hooks import plugin_manager

    factory = getattr(plugin_manager, "get_plugin_manager", plugin_manager.make_plugin_manager)
    return factory(list(plugins or ()), blocked_names(block))


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


# ---------------------------------------------------------------------------
# Running a tree
# ---------------------------------------------------------------------------


def add_run_arguments(parser: argparse.ArgumentParser, manager: Any = None) -> None:
    """The options of ``run-tree`` and ``armtree run`` (without the plugin options),
    and those the plugins of ``manager`` add (``armtree_run_options``)."""
    parser.add_argument("tree", metavar="TREE", help="tree file or name of a shipped tree")
    parser.add_argument("--rig", metavar="PROFILE", help="hardware profile (default: the tree's)")
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a profile key, tree parameter or blackboard value (YAML-typed)",
    )
    parser.add_argument(
        "--seed", type=seed_value, default=0, help="seed of the simulation (default 0)"
    )
    parser.add_argument(
        "--realtime", action="store_true", help="tick on the wall clock (hardware always does)"
    )
    parser.add_argument(
        "--record", metavar="DIR", help="write the run log to DIR (default runs/<tree>-<time>/)"
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace a run already recorded in the --record folder",
    )
    parser.add_argument(
        "--timeout",
        type=float,
        metavar="SECONDS",
        help="fail after SECONDS on the run clock (default on the simulation: 600; inf: none)",
    )
    parser.add_argument("--max-ticks", type=int, metavar="N", help="fail after N ticks")
    parser.add_argument("--quiet", action="store_true", help="no live view")
    if manager is not None:
        manager.hook.armtree_run_options(parser=parser)


def run_from_args(args: argparse.Namespace, manager: Any = None) -> int:
    """Load, validate and run the tree the options name; return the exit code."""
    if args.timeout is not None and not args.timeout > 0:
        raise ConfigError(
            f"--timeout {args.timeout:g}: give a positive number of seconds (inf: no limit)"
        )
    if args.max_ticks is not None and args.max_ticks <= 0:
        raise ConfigError(f"--max-ticks {args.max_ticks}: give a positive number of ticks")
    return _run_loaded(args, manager)


def claim_record_folder(value: str, overwrite: bool) -> Any:
    """The lock of the ``--record`` folder ``value``, checked (exit 2 naming it when it is
    no folder one may write, when another run is writing there, or when it holds a run
    and ``overwrite`` is not given; with it, that run's files are removed)."""
    from armtree.api.folder_lock import FolderLock
    from armtree.api.output_paths import clear_held, output_folder

    where = f"--record {value}"
    out = output_folder(value, "--record")
    lock = FolderLock(
        out,
        where,
        RUN_LOCK,
        "two runs would mix their records: wait for it to end, or give another folder",
    )
    try:
        clear_held(out, RUN_FILES, overwrite, where, "run")
    except BaseException:
        lock.release()
        raise
    return lock


def _run_loaded(args: argparse.Namespace, manager: Any) -> int:
    from armtree.loader.tree_loader import load_tree

    if manager is None:
        manager = plugin_manager_for(getattr(args, "plugin", None), getattr(args, "block", None))
    tree = load_tree(args.tree, rig=args.rig, overrides=args.overrides, manager=manager)
    lock = None
    created = False
    try:
        if args.record is not None:  # after the tree validates: a typo leaves no folder behind
            created = not os.path.lexists(args.record)
            lock = claim_record_folder(args.record, getattr(args, "overwrite", False))
        return _run_claimed(args, manager, tree)
    except OSError as exc:
        if exc.filename is None and exc.errno in DISK_FULL and args.record is not None:
            # The record's writers do not name their file: the folder is what the user gave.
            raise OSError(exc.errno, exc.strerror, f"--record {args.record}") from exc
        raise
    finally:
        if lock is not None:
            lock.release()
            if created:  # refused before it recorded (a port in use): leave no empty folder
                _remove_if_unused(Path(args.record))


def _remove_if_unused(folder: Path) -> None:
    """Remove ``folder`` when it holds nothing but the run lock."""
    with contextlib.suppress(OSError):
        if [p.name for p in folder.iterdir()] == [RUN_LOCK]:
            (folder / RUN_LOCK).unlink()
            folder.rmdir()


def _run_claimed(args: argparse.Namespace, manager: Any, tree: Any) -> int:
    from armtree.runtime.display import print_summary
    from armtree.runtime.run_start import default_timeout
    from armtree.runtime.runner import run

    timeout = args.timeout
    if timeout is None:
        timeout = default_timeout(tree.profile, args.realtime, manager)
    result = run(
        tree,
        seed=args.seed,
        realtime=args.realtime,
        record=args.record,
        timeout=timeout,
        max_ticks=args.max_ticks,
        quiet=args.quiet,
        manager=manager,
        debug=getattr(args, "debug", False),
        settings={k: v for k, v in vars(args).items() if k != "manager"},
    )
    if getattr(args, "debug", False) and result.traceback:
        print(result.traceback, file=sys.stderr, end="")
    print_summary(result)
    if result.record_errors:
        folder = args.record
        if folder is None and result.log_path is not None:
            folder = result.log_path.parent
        for error in result.record_errors:
            print(f"--record {folder}: {error}; {DISK_FULL_ADVICE}", file=sys.stderr)
        if result.exit_code == EXIT_OK:
            return EXIT_USAGE
    if result.status == "INTERRUPTED":
        print(result.message, file=sys.stderr)
    elif (
        result.exit_code == EXIT_FAILURE and result.traceback and not getattr(args, "debug", False)
    ):
        print(f"{result.message} (run again with --debug for the traceback)", file=sys.stderr)
    return result.exit_code


def run_tree_main(argv: Sequence[str] | None = None) -> int:
    """``run-tree TREE [options]``: run a tree on its rig; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if "--version" in argv:  # before any plugin loads: it answers even when one is broken
        print(version_text("run-tree"))
        return EXIT_OK
    pre = argparse.ArgumentParser(add_help=False)
    plugin_options(pre)
    known, _ = pre.parse_known_args(argv)
    # The plugins are loaded before the options are parsed: they may add options.
    holder: dict[str, Any] = {}

    def build() -> int:
        holder["manager"] = manager = plugin_manager_for(known.plugin, known.block)
        parser = argparse.ArgumentParser(
            prog="run-tree", description="Run a behaviour tree on a rig (simulated by default)."
        )
        add_run_arguments(parser, manager)
        plugin_options(parser)
        add_version_option(parser, "run-tree")
        holder["parser"] = parser
        return EXIT_OK

    code = guarded(build, known.debug)
    if code != EXIT_OK:
        return code
    args = holder["parser"].parse_args(argv)
    return guarded(lambda: run_from_args(args, holder["manager"]), args.debug)


class RunCommand:
    """``armtree run``: the same as ``run-tree``; ``manager``'s plugins may add options."""

    help = "run a tree (the same as run-tree)"

    def __init__(self, manager: Any = None) -> None:
        self.manager = manager

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add the run options."""
        add_run_arguments(parser, self.manager)

    def run(self, args: argparse.Namespace) -> int:
        """Run the tree; the exit code."""
        return run_from_args(args, getattr(args, "manager", None))


class BenchCommand:
    """``armtree bench``: run benchmarks with a progress bar."""

    help = "run benchmarks (the runtime's built in, and benchmarks/bench_*.py scripts)"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add the bench options."""
        from .bench import configure_bench

        configure_bench(parser)

    def run(self, args: argparse.Namespace) -> int:
        """Run the chosen benchmarks; the exit code."""
        from .bench import run_bench

        return run_bench(args)


# ---------------------------------------------------------------------------
# armtree SUBCOMMAND
# ---------------------------------------------------------------------------


def _commands(manager: Any) -> dict[str, Any]:
    commands: dict[str, Any] = {"run": RunCommand(manager), "bench": BenchCommand()}
    commands.update(manager.components("command").instances("command", OWN_COMMANDS))
    return commands


def configure_command(command: Any, parser: argparse.ArgumentParser, manager: Any) -> None:
    """``command.configure(parser)``, handing it the plugin manager when its ``configure``
    takes one (``configure(parser, manager)``: its options may come from plugins)."""
    import inspect  # loaded with the plugins already

    if "manager" in inspect.signature(command.configure).parameters:
        command.configure(parser, manager=manager)
    else:
        command.configure(parser)


def _asks_version(argv: Sequence[str]) -> bool:
    """True when ``--version`` comes before the subcommand (after options only)."""
    if "--version" not in argv:
        return False
    head, i = list(argv[: list(argv).index("--version")]), 0
    while i < len(head):
        if head[i] in ("-p", "--plugin"):
            i += 2
        elif head[i].startswith("-"):
            i += 1
        else:
            return False
    return True


def main(argv: Sequence[str] | None = None) -> int:
    """``armtree SUBCOMMAND [options]``; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if _asks_version(argv):  # before any plugin loads: it answers even when one is broken
        print(version_text("armtree"))
        return EXIT_OK
    pre = argparse.ArgumentParser(add_help=False)
    plugin_options(pre)
    known, _ = pre.parse_known_args(argv)
    holder: dict[str, Any] = {}

    def build() -> int:
        holder["manager"] = plugin_manager_for(known.plugin, known.block)
        holder["commands"] = _commands(holder["manager"])
        return EXIT_OK

    code = guarded(build, known.debug)
    if code != EXIT_OK:
        return code
    manager, commands = holder["manager"], holder["commands"]
    parser = argparse.ArgumentParser(
        prog="armtree", description="Behaviour trees in YAML for vision-guided robot arms."
    )
    plugin_options(parser, suppress=True)
    add_version_option(parser, "armtree")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in sorted(commands):
        command = commands[name]
        summary = getattr(command, "help", "") or ""
        child = sub.add_parser(name, help=summary, description=summary)
        plugin_options(child, suppress=True)
        configure_command(command, child, manager)
    args = parser.parse_args(argv)
    args.manager = manager
    debug = bool(getattr(args, "debug", False))
    return guarded(lambda: int(commands[args.command].run(args) or 0), debug)
