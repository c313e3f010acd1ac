"""Running a calibration or experiment tree from a command: progress, device, result.

The command's profile includes the calibration file (``-o FILE``) when it exists,
so a calibration is measured with the ones made before it; the tree's
``visit_poses`` reports its progress on the blackboard key
``calibration_progress``, which a rich progress bar shows. On hardware, where no
simulation supplies ``rig.reference``, the operator is asked at the console.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import py_trees

import armtree
from armtree.api.rig import Rig
from armtree.hooks.plugin_manager import PluginManager
from armtree.runtime.display import NullView
from armtree.runtime.display import Run as RunView
from armtree.runtime.runner import Run

from .operator import OperatorMeasuringDevice


class OperatorFallback:
    """Plugin object: hands ``rig.reference`` the operator when nothing else did."""

    @armtree.hookimpl(trylast=True)
    def armtree_rig_ready(self, rig: Rig, context: Any) -> None:
        if getattr(rig, "reference", None) is None:
            rig.reference = OperatorMeasuringDevice()


class ProgressView(NullView):
    """A rich progress bar fed by the blackboard's ``calibration_progress``."""

    def __init__(self, title: str) -> None:
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
        )

        self.progress = Progress(
            TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
            TextColumn("{task.fields[what]}"), console=Console(stderr=True), transient=False,
        )  # fmt: skip
        self.task = self.progress.add_task(title, total=None, what="")

    def start(self, run: RunView) -> None:
        self.progress.start()

    def update(self, run: RunView, changes: Any) -> None:
        value = py_trees.blackboard.Blackboard.storage.get("/calibration_progress")
        if isinstance(value, dict):
            self.progress.update(
                self.task,
                total=value.get("total"),
                completed=value.get("done", 0),
                what=value.get("what", ""),
            )

    def message(self, text: str) -> None:
        self.progress.console.print(text)

    def stop(self, run: RunView) -> None:
        self.progress.stop()

    def abort(self) -> None:
        self.progress.stop()


def profile_overrides(out: str | None, overrides: list[str]) -> list[str]:
    """``--set`` overrides with the calibration file ``out`` included when it exists."""
    extra = [f"include={Path(out).resolve()}"] if out and Path(out).is_file() else []
    return extra + list(overrides)


def run_tree(
    tree: str,
    rig: str,
    overrides: list[str],
    seed: int,
    title: str,
    manager: PluginManager | None = None,
) -> Any:
    """Run ``tree`` on profile ``rig`` with a progress bar; the RunResult and the Run."""
    from armtree.loader.tree_loader import load_tree

    if manager is None:
        from armtree.hooks.plugin_manager import PluginManager

        manager = PluginManager()
        manager.load_entry_points()
    if manager.pm.get_plugin("calibration_operator") is None:
        manager.register(OperatorFallback(), "calibration_operator")
    loaded = load_tree(tree, rig=rig, overrides=overrides, manager=manager)
    run = Run(loaded, None, seed=seed, quiet=True, manager=manager, view=ProgressView(title))
    result = run.execute()
    return result, run


def report(result: Any, what: str) -> int:
    """Print the run's ending (the failing step's reason) and return the exit code."""
    if result.status == "SUCCESS":
        return 0
    print(f"{what}: {result.status.lower()}: {result.message}", file=sys.stderr)
    return result.exit_code


__all__ = ["OperatorFallback", "ProgressView", "profile_overrides", "report", "run_tree"]
