"""A run's lifecycle hooks: called through pluggy, a plugin's exception reported, not fatal."""

from __future__ import annotations

import sys
from typing import Any, Protocol

from armtree.hooks.hook_calls import call_isolated, has_implementations
from armtree.hooks.plugin_manager import PluginManager
from armtree.runtime.display import NullView
from armtree.runtime.runlog import LoggedRun


class HookedRun(LoggedRun, Protocol):
    """What :class:`RunHooks` reads of its run: the plugin manager, and where to report."""

    manager: PluginManager | None
    view: NullView


class RunHooks:
    """Calls the lifecycle hooks (``armtree_run_started``, ``armtree_tick``, ...) of one run.

    :meth:`call` lets an exception end the run (a plugin refusing it);
    :meth:`notify` reports a plugin's exception as a ``hook_error`` in the run log,
    tells the user once per plugin and hook, and goes on with the other plugins.
    The run's plugin manager is looked up at each call: a run may build it late.
    """

    def __init__(self, run: HookedRun) -> None:
        self._run = run
        self._told: set[tuple[str, str]] = set()

    def _pm(self) -> Any:
        manager = self._run.manager
        return None if manager is None else manager.pm

    def has(self, name: str) -> bool:
        """True when some plugin implements hook ``name``."""
        return has_implementations(self._pm(), name)

    def call(self, name: str, **kwargs: Any) -> Any:
        """Call hook ``name`` through pluggy; an exception propagates."""
        pm = self._pm()
        return None if pm is None else getattr(pm.hook, name)(**kwargs)

    def notify(self, name: str, **kwargs: Any) -> Any:
        """Call hook ``name`` through pluggy; a plugin that raises is reported and left out."""
        return call_isolated(self._pm(), name, self._error, **kwargs)

    def _error(self, name: str, plugin: str, exc: BaseException) -> None:
        run = self._run
        run.log.event(
            run.tick_count,
            run.clock.now(),
            "hook_error",
            hook=name,
            plugin=plugin,
            error=f"{type(exc).__name__}: {exc}",
        )
        if (name, plugin) not in self._told:
            self._told.add((name, plugin))
            text = f"plugin {plugin!r}: {name} raised {type(exc).__name__}: {exc}"
            run.view.message(text)
            print(f"warning: {text} (the run goes on)", file=sys.stderr)
