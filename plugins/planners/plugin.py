"""Registration of the built-in planners (``direct``, ``prm``) and the ``workspace`` command."""

from __future__ import annotations

from typing import Any

import armtree
from armtree.api.rig import Planner
from armtree.runtime.runner import Run

from .direct import direct_factory
from .prm import prm_factory
from .workspace_command import WorkspaceCommand


@armtree.hookimpl
def armtree_planners() -> dict[str, Any]:
    """The built-in motion planners."""
    return {"direct": direct_factory, "prm": prm_factory}


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """``armtree workspace``."""
    return {"workspace": WorkspaceCommand()}


@armtree.hookimpl
def armtree_run_started(run: Run) -> None:
    """Connect the rig's planner to the run log (:attr:`armtree.api.rig.Planner.report`).

    A planner asked again and again from the same believed start (every inverse
    kinematics solution, every scan pose) reports stepping out of its contact once.
    """
    planner = getattr(getattr(run, "rig", None), "planner", None)
    report_event = getattr(run, "report_event", None)
    if not isinstance(planner, Planner) or report_event is None:
        return
    last: tuple[str, str] | None = None

    def report(event: str, message: str, **data: Any) -> None:
        nonlocal last
        key = (event, repr(data.get("start")))
        if key != last:
            last = key
            report_event(event, message, **data)

    planner.report = report
