"""One run of a sweep: what a child process is told, what it does, and what it reports.

A :class:`RunTask` travels as JSON to the process that runs it; :func:`run_task`
loads the tree there with a plugin manager of its own and runs it quietly, its
run log under the task's folder; the :class:`Outcome` it returns (a plain
mapping) is all the sweep keeps of the run.
"""

from __future__ import annotations

import dataclasses
import json
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from armtree.api.outcomes.failures import chain_text

#: Outcome statuses besides the run's own (SUCCESS, FAILURE, INTERRUPTED).
TIMEOUT, DIED, ERROR = "TIMEOUT", "DIED", "ERROR"

Outcome = dict[str, Any]


@dataclass(frozen=True)
class RunTask:
    """One seed of a sweep: the tree and its options, and the folder its run writes to.

    ``timeout`` is the run's own limit on the run clock (``--timeout``), ``attempt``
    counts retries after a run's process died, ``settings`` the values of the options
    plugins added to the sweep (the run gets them in ``run.settings``), ``preload``
    the modules plugins said the run will import (a forker imports them before it forks).
    """

    tree: str
    seed: int
    run_dir: str
    rig: str | None = None
    overrides: tuple[str, ...] = ()
    plugins: tuple[str, ...] = ()
    blocked: tuple[str, ...] = ()
    timeout: float | None = None
    attempt: int = 1
    settings: dict[str, Any] = dataclasses.field(default_factory=dict)
    preload: tuple[str, ...] = ()

    def to_json(self) -> str:
        """The task as one line of JSON."""
        return json.dumps(dataclasses.asdict(self))

    @classmethod
    def from_json(cls, text: str) -> RunTask:
        """The task from :meth:`to_json`."""
        data = json.loads(text)
        for key in ("overrides", "plugins", "blocked", "preload"):
            data[key] = tuple(data.get(key) or ())
        data["settings"] = dict(data.get("settings") or {})
        return cls(**data)

    @property
    def result_path(self) -> Path:
        """Where the child writes its outcome (JSON)."""
        return Path(self.run_dir) / "outcome.json"

    def retry(self) -> RunTask:
        """The same run, once more."""
        return dataclasses.replace(self, attempt=self.attempt + 1)


def load_task(task: RunTask) -> tuple[Any, Any]:
    """The task's plugin manager and its tree, loaded and checked (ConfigError if invalid)."""
    from armtree.hooks.plugin_manager import make_plugin_manager
    from armtree.loader.tree_loader import load_tree

    manager = make_plugin_manager(task.plugins, task.blocked)
    return manager, load_tree(task.tree, rig=task.rig, overrides=task.overrides, manager=manager)


def load_key(task: RunTask) -> tuple:
    """What :func:`load_task` depends on: tasks with the same key load the same tree."""
    return (task.tree, task.rig, task.overrides, task.plugins, task.blocked)


def run_task(task: RunTask, loaded: tuple[Any, Any] | None = None) -> tuple[Outcome, int]:
    """Run the task's tree in this process; its outcome and exit code.

    Called in a fresh child process: a new rig, the process-wide blackboard cleared
    by the run itself. ``loaded`` is :func:`load_task`'s result for this task, when
    the forker loaded it before forking (the child's copy is its own); else the
    tree is loaded here.
    """
    from armtree.runtime.run_start import default_timeout
    from armtree.runtime.runner import run

    manager, tree = loaded if loaded is not None else load_task(task)
    # As run-tree: a simulated run that makes no progress ends at the default timeout.
    timeout = task.timeout
    if timeout is None:
        timeout = default_timeout(tree.profile, False, manager)
    result = run(
        tree,
        seed=task.seed,
        record=True,
        runs_dir=task.run_dir,
        timeout=timeout,
        quiet=True,
        manager=manager,
        stop_key=False,
        settings=run_settings(task),
    )
    return outcome_of(task, result), result.exit_code


def run_settings(task: RunTask) -> dict[str, Any]:
    """``run.settings`` of the task's run: the sweep's plugin options, and the run's
    ``tree``, ``rig``, ``overrides`` and ``seed`` as run-tree's options would give them,
    with ``sweep_run_dir``, the run's folder."""
    return {
        **task.settings,
        "tree": task.tree,
        "rig": task.rig,
        "overrides": list(task.overrides),
        "seed": task.seed,
        "sweep_run_dir": task.run_dir,
    }


def reason_of(result: Any) -> str:
    """Why a run did not succeed, in one line (empty for a success).

    A false success names the expectations that failed; a tree failure its chain of
    reasons from the root to the leaf; anything else (a timeout, an interrupt, a
    collision) the run's message.
    """
    if result.verdict == "success":
        return ""
    if result.verdict == "false success":
        failed = "; ".join(r.expect for r in result.expectations if r.failed)
        return f"false success: {failed}"
    if result.chain:
        return chain_text(result.chain)
    return result.message or result.status


def outcome_of(task: RunTask, result: Any) -> Outcome:
    """What the sweep keeps of a finished run."""
    return {
        "seed": task.seed,
        "attempt": task.attempt,
        "run_dir": task.run_dir,
        "status": result.status,
        "verdict": result.verdict,
        "exit_code": result.exit_code,
        "ticks": result.ticks,
        "seconds": result.seconds,
        "wall_seconds": result.wall_seconds,
        "reason": reason_of(result),
        "message": result.message,
        "expectations": [
            {"expect": r.expect, "status": r.status, "measured": r.measured}
            for r in result.expectations
        ],
        "events": dict(Counter(e["event"] for e in result.events)),
        "log": str(result.log_path) if result.log_path else None,
    }


def failed_outcome(task: RunTask, status: str, reason: str, **extra: Any) -> Outcome:
    """The outcome of a run that did not end by itself: killed, died, or broke."""
    return {
        "seed": task.seed,
        "attempt": task.attempt,
        "run_dir": task.run_dir,
        "status": status,
        "verdict": "failure",
        "exit_code": None,
        "ticks": None,
        "seconds": None,
        "wall_seconds": extra.pop("wall_seconds", None),
        "reason": reason,
        "message": reason,
        "expectations": [],
        "events": {},
        "log": None,
        **extra,
    }
