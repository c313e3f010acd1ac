"""The command lines: ``run-tree TREE ...`` and ``armtree SUBCOMMAND ...``.

``armtree`` dispatches to every command registered through the
``armtree_commands`` hook, plus its own ``run`` (the same as ``run-tree``) and
``bench``; exit codes as :mod:`armtree.cli.options` states them. This module loads
the plugins (and numpy, OpenCV, py_trees with them) only once ``--version`` is ruled
out, through :mod:`armtree.cli.run_command` and :mod:`armtree.cli.subcommands`.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

from .options import EXIT_OK, add_version_option, guarded, plugin_options, version_text


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
        from .run_command import add_run_arguments, plugin_manager_for

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
    from .run_command import run_from_args

    return guarded(lambda: run_from_args(args, holder["manager"]), args.debug)


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
        from .run_command import plugin_manager_for
        from .subcommands import commands_for

        holder["manager"] = plugin_manager_for(known.plugin, known.block)
        holder["commands"] = commands_for(holder["manager"])
        return EXIT_OK

    code = guarded(build, known.debug)
    if code != EXIT_OK:
        return code
    from .subcommands import configure_command  # loaded by build()

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
