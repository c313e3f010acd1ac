"""What plugins see of a sweep (:class:`Sweep`), and the calls to their sweep hooks.

Plugins add options to ``armtree sweep`` (``armtree_sweep_options``), hear that it
starts (``armtree_sweep_started``, where they may refuse it), that each run ended
(``armtree_sweep_run_finished``) and that it is over (``armtree_sweep_finished``).
Each run, in its own process, gets the plugins' option values as ``run.settings``.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from armtree.api.sweep import Sweep
from armtree.hooks.hook_calls import call_isolated
from armtree.hooks.plugin_manager import PluginManager

#: The parser default naming the options the plugins added (their ``dest``).
PLUGIN_DESTS = "sweep_plugin_options"


def add_plugin_options(parser: argparse.ArgumentParser, manager: PluginManager | None) -> None:
    """The options the plugins of ``manager`` add to the sweep (``armtree_sweep_options``),
    their ``dest`` noted in the parser's default :data:`PLUGIN_DESTS`."""
    if manager is None:
        return
    before = {action.dest for action in parser._actions}
    manager.hook.armtree_sweep_options(parser=parser)
    added = tuple(a.dest for a in parser._actions if a.dest not in before)
    parser.set_defaults(**{PLUGIN_DESTS: added})


def plugin_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The values of the plugins' options in ``args``."""
    return {dest: getattr(args, dest, None) for dest in getattr(args, PLUGIN_DESTS, ())}


class SweepHooks:
    """Calls the sweep hooks of one sweep's plugin manager."""

    def __init__(self, manager: PluginManager) -> None:
        self.pm = getattr(manager, "pm", None)
        self._told: set[tuple[str, str]] = set()

    def started(self, sweep: Sweep) -> None:
        """``armtree_sweep_started``; an exception (a refusal) propagates."""
        if self.pm is not None:
            self.pm.hook.armtree_sweep_started(sweep=sweep)

    def notify(self, name: str, **kwargs: Any) -> None:
        """Call hook ``name``; a plugin that raises is reported once and left out."""
        call_isolated(self.pm, name, self._error, **kwargs)

    def _error(self, name: str, plugin: str, exc: BaseException) -> None:
        if (name, plugin) not in self._told:
            self._told.add((name, plugin))
            print(
                f"warning: plugin {plugin!r}: {name} raised {type(exc).__name__}: {exc} "
                "(the sweep goes on)",
                file=sys.stderr,
            )


__all__ = ["SweepHooks", "add_plugin_options", "plugin_settings"]
