"""What a run needs before its first tick: its clock, its plugin manager, and its run log
opened with the ``start`` record."""

from __future__ import annotations

import time
from pathlib import Path

from armtree.api.clock import Clock, VirtualClock, WallClock
from armtree.api.views import ProfileView
from armtree.hooks.plugin_manager import PluginManager, get_plugin_manager
from armtree.loader.tree import Tree

from .rig_builder import uses_real_hardware
from .runlog import RunLog, default_run_dir


def choose_clock(
    profile: ProfileView | None, realtime: bool, manager: PluginManager | None
) -> Clock:
    """A wall clock when asked (``realtime``) or when the profile names real hardware,
    else a virtual one."""
    if realtime or (
        profile is not None and uses_real_hardware(profile, manager.registry if manager else None)
    ):
        return WallClock()
    return VirtualClock()


#: ``run-tree``'s ``--timeout`` for a run on the virtual clock (the simulation) when none
#: is given, seconds of run time: five times the longest a shipped tree's run takes
#: (docs/benchmarks.md, "Runtime and what it carries"), so a tree that makes no progress ends on its own.
DEFAULT_SIM_TIMEOUT_S = 600.0


def default_timeout(
    profile: ProfileView | None, realtime: bool, manager: PluginManager | None
) -> float | None:
    """:data:`DEFAULT_SIM_TIMEOUT_S` for a run on the virtual clock; None (no limit) on
    the wall clock (``realtime``, or a profile naming real hardware)."""
    if not choose_clock(profile, realtime, manager).virtual:
        return None
    return DEFAULT_SIM_TIMEOUT_S


def plugin_manager(tree: Tree) -> PluginManager:
    """The plugin manager of ``tree``'s profile, else one for the tree's ``plugins:``."""
    manager = getattr(tree.profile, "manager", None)
    if isinstance(manager, PluginManager):
        return manager
    return get_plugin_manager(tree.plugins or ())


def choose_record_dir(
    record: Path | str | bool | None, tree_name: str, runs_dir: Path
) -> Path | None:
    """Where the run is recorded: ``record`` when it names a directory, a fresh
    ``runs_dir/<tree>-<time>/`` for ``None`` or ``True``, nowhere for ``False``."""
    if record is False:
        return None
    if record in (None, True):
        return default_run_dir(tree_name, runs_dir)
    return Path(record)  # type: ignore[arg-type]


def open_log(directory: Path, tree: Tree, *, seed: int, tick_hz: float, clock: Clock) -> RunLog:
    """The run log ``directory/run.jsonl``, its ``start`` record written."""
    log = RunLog(directory / "run.jsonl")
    log.write(
        {
            "kind": "start",
            "tick": 0,
            "t": 0.0,
            "tree": tree.name,
            "source": str(getattr(tree, "source", "") or ""),
            "seed": seed,
            "tick_hz": tick_hz,
            "clock": "virtual" if clock.virtual else "wall",
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "blackboard": dict(getattr(tree, "blackboard", None) or {}),
        }
    )
    return log
