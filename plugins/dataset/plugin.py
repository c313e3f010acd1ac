"""The dataset's hooks: ``--dataset`` for run-tree and sweeps, ``armtree dataset``."""

from __future__ import annotations

import argparse
from typing import Any

import armtree
from armtree.api.sweep import Sweep
from armtree.runtime.runner import Run

from .session import KEEP_CHOICES, KEY, RunDataset, SweepDataset


def fps_number(text: str) -> int:
    """An argparse type: a whole, positive number of frames a second."""
    try:
        fps = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: give a whole number of frames a second"
        ) from None
    if fps <= 0:
        raise argparse.ArgumentTypeError(f"{fps}: give a positive number of frames a second")
    return fps


def _options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("dataset")
    group.add_argument(
        "--dataset",
        metavar="DIR",
        help="append each kept run as an episode to the LeRobotDataset v3.0 in DIR "
        "(made if new; pip install 'armtree[dataset]')",
    )
    group.add_argument(
        "--dataset-keep",
        choices=KEEP_CHOICES,
        default="success",
        help="which runs become episodes: judged successes (default), or all that ended "
        "by themselves (interrupted runs never)",
    )
    group.add_argument(
        "--dataset-fps",
        type=fps_number,
        metavar="N",
        help="frames a second of the episodes (default: the dataset's, 10 for a new one); "
        "must divide the tree's tick rate",
    )


@armtree.hookimpl
def armtree_run_options(parser: argparse.ArgumentParser) -> None:
    """``--dataset DIR``, ``--dataset-keep all|success``, ``--dataset-fps N``."""
    _options(parser)


@armtree.hookimpl
def armtree_run_opening(run: Run) -> None:
    """Open the dataset (checked and locked) before anything is built: bad input is exit 2."""
    if not run.settings.get("dataset"):
        return
    session = RunDataset(run)
    run.plugin_state[KEY] = session
    run.closers.append(session.close)


@armtree.hookimpl
def armtree_run_started(run: Run) -> None:
    """Start recording the rig."""
    session = run.plugin_state.get(KEY)
    if session is not None:
        session.start(run)


@armtree.hookimpl
def armtree_tick(run: Run) -> None:
    """Take the frames due."""
    session = run.plugin_state.get(KEY)
    if session is not None:
        session.tick(run)


@armtree.hookimpl
def armtree_run_finished(run: Run, result: Any) -> None:
    """Keep the episode (append it, or stage it for the sweep) or drop it."""
    session = run.plugin_state.get(KEY)
    if session is not None:
        session.finish(run, result)


@armtree.hookimpl
def armtree_sweep_options(parser: argparse.ArgumentParser) -> None:
    """The same ``--dataset`` options for ``armtree sweep``."""
    _options(parser)


@armtree.hookimpl
def armtree_sweep_started(sweep: Sweep) -> None:
    """Open the dataset (checked and locked) before the first run; its runs stage episodes."""
    if not sweep.settings.get("dataset"):
        return
    session = SweepDataset(sweep)
    sweep.plugin_state[KEY] = session
    # Every run encodes its camera video: PyAV loaded once, not once a run.
    sweep.preload.append("av")
    sweep.closers.append(session.close)


@armtree.hookimpl
def armtree_sweep_run_finished(sweep: Sweep, outcome: dict[str, Any]) -> None:
    """Hand the run's staged episode to the appender."""
    session = sweep.plugin_state.get(KEY)
    if session is not None:
        session.ended_run(outcome)


@armtree.hookimpl
def armtree_sweep_finished(sweep: Sweep, outcomes: list[dict[str, Any]], interrupted: bool) -> None:
    """Append the rest in seed order and say what the dataset got."""
    session = sweep.plugin_state.get(KEY)
    if session is not None:
        session.finish()
        print(session.summary(), flush=True)


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """``armtree dataset info|check DIR``."""
    from .commands import DatasetCommand

    return {"dataset": DatasetCommand()}
