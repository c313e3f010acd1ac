"""Running a tree from the command line: ``run-tree``'s options, the ``--record``
folder's lock, and the run with its summary (``armtree run`` is the same command)."""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from armtree.api.folder_lock import FolderLock
from armtree.errors import ConfigError
from armtree.hooks import plugin_manager
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.tree import Tree

from .options import (
    DISK_FULL,
    DISK_FULL_ADVICE,
    EXIT_FAILURE,
    EXIT_OK,
    EXIT_USAGE,
    RUN_FILES,
    RUN_LOCK,
    add_set_option,
    blocked_names,
    seed_value,
)


def plugin_manager_for(plugins: Sequence[str] | None, block: Sequence[str] | None) -> PluginManager:
    """The plugin manager for these command-line options (shared per process)."""
    return plugin_manager.get_plugin_manager(list(plugins or ()), blocked_names(block))


def add_run_arguments(
    parser: argparse.ArgumentParser, manager: PluginManager | None = None
) -> None:
    """The options of ``run-tree`` and ``armtree run`` (without the plugin options),
    and those the plugins of ``manager`` add (``armtree_run_options``)."""
    parser.add_argument("tree", metavar="TREE", help="tree file or name of a shipped tree")
    parser.add_argument("--rig", metavar="PROFILE", help="hardware profile (default: the tree's)")
    add_set_option(
        parser, "override a profile key, tree parameter or blackboard value (YAML-typed)"
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


def run_from_args(args: argparse.Namespace, manager: PluginManager | None = None) -> int:
    """Load, validate and run the tree the options name; return the exit code."""
    if args.timeout is not None and not args.timeout > 0:
        raise ConfigError(
            f"--timeout {args.timeout:g}: give a positive number of seconds (inf: no limit)"
        )
    if args.max_ticks is not None and args.max_ticks <= 0:
        raise ConfigError(f"--max-ticks {args.max_ticks}: give a positive number of ticks")
    return _run_loaded(args, manager)


def claim_record_folder(value: str, overwrite: bool) -> FolderLock:
    """The lock of the ``--record`` folder ``value``, checked (exit 2 naming it when it is
    no folder one may write, when another run is writing there, or when it holds a run
    and ``overwrite`` is not given; with it, that run's files are removed)."""
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


def _run_loaded(args: argparse.Namespace, manager: PluginManager | None) -> int:
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


def _run_claimed(args: argparse.Namespace, manager: PluginManager, tree: Tree) -> int:
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


class RunCommand:
    """``armtree run``: the same as ``run-tree``; ``manager``'s plugins may add options."""

    help = "run a tree (the same as run-tree)"

    def __init__(self, manager: PluginManager | None = None) -> None:
        self.manager = manager

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add the run options."""
        add_run_arguments(parser, self.manager)

    def run(self, args: argparse.Namespace) -> int:
        """Run the tree; the exit code."""
        return run_from_args(args, getattr(args, "manager", None))
