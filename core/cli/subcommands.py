"""``armtree``'s subcommands: its own (``run``, ``bench``) and those plugins register
through ``armtree_commands``, each configured with the plugin manager when it asks."""

from __future__ import annotations

import argparse
import inspect
from typing import Any

from armtree.hooks.plugin_manager import PluginManager

from .run_command import RunCommand

#: Commands the CLI provides itself; a plugin may not register these names.
OWN_COMMANDS = ("run", "bench")


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


def commands_for(manager: PluginManager) -> dict[str, Any]:
    """Every subcommand by name: armtree's own and those the plugins register."""
    commands: dict[str, Any] = {"run": RunCommand(manager), "bench": BenchCommand()}
    commands.update(manager.components("command").instances("command", OWN_COMMANDS))
    return commands


def configure_command(
    command: Any, parser: argparse.ArgumentParser, manager: PluginManager
) -> None:
    """``command.configure(parser)``, handing it the plugin manager when its ``configure``
    takes one (``configure(parser, manager)``: its options may come from plugins)."""
    if "manager" in inspect.signature(command.configure).parameters:
        command.configure(parser, manager=manager)
    else:
        command.configure(parser)
