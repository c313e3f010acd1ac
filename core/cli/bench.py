"""Benchmarks that ship with the package, and the ``armtree bench`` command.

The runtime benchmark ticks the same 101-node tree bare in py_trees
(``root.tick_once()``; ``BehaviourTree.tick()`` is shown for reference) and
through :func:`armtree.run` with the run log and status-change tracking on
(set-up and halt included), alternating the two in many short rounds in one
process and keeping each one's best round. Times are the process's CPU time,
so other work on the machine disturbs the ratio as little as possible.

``armtree bench`` runs the built-in benchmarks and every ``bench_*.py`` script
of a ``benchmarks/`` folder (the working directory's by default), with a
progress bar, and prints their figures.
"""

from __future__ import annotations

import argparse
import functools
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import py_trees
from py_trees.common import ParallelPolicy

#: Overhead goal of the runtime over bare py_trees, percent.
RUNTIME_OVERHEAD_GOAL = 10.0


def bench_tree(churn: bool = False) -> py_trees.behaviour.Behaviour:
    """A 101-node tree that never finishes: a parallel of 10 composites of 9 leaves.

    Steady (default): sequences of 8 ``Success`` leaves and a ``Running`` one;
    statuses settle after the first tick. ``churn``: parallels of 8
    ``TickCounter`` leaves (RUNNING for 1 to 4 ticks, then SUCCESS, again and
    again) and a ``Running`` one, so every leaf is ticked and about a third of
    the statuses change on every tick.
    """
    branches: list[py_trees.behaviour.Behaviour] = []
    for b in range(10):
        leaves: list[py_trees.behaviour.Behaviour]
        if churn:
            leaves = [
                py_trees.behaviours.TickCounter(
                    name=f"count{b}.{i}",
                    duration=1 + (i + b) % 4,
                    completion_status=py_trees.common.Status.SUCCESS,
                )
                for i in range(8)
            ]
        else:
            leaves = [py_trees.behaviours.Success(name=f"ok{b}.{i}") for i in range(8)]
        runner = py_trees.behaviours.Running(name=f"run{b}")
        if churn:
            branches.append(
                py_trees.composites.Parallel(
                    f"par{b}",
                    policy=ParallelPolicy.SuccessOnSelected(children=[runner], synchronise=False),
                    children=[*leaves, runner],
                )
            )
        else:
            branches.append(
                py_trees.composites.Sequence(f"seq{b}", memory=False, children=[*leaves, runner])
            )
    return py_trees.composites.Parallel(
        "root", policy=ParallelPolicy.SuccessOnAll(synchronise=False), children=branches
    )


@dataclass
class RuntimeFigures:
    """Ticks per second bare and through armtree, and the overhead in percent."""

    variant: str
    nodes: int
    ticks: int
    bare_tps: float
    armtree_tps: float
    behaviour_tree_tps: float
    changes_per_tick: float
    snapshot_tps: float

    @property
    def overhead_percent(self) -> float:
        """How much longer a tick takes through armtree than bare, in percent."""
        return (self.bare_tps / self.armtree_tps - 1.0) * 100.0

    def lines(self) -> list[str]:
        """Human-readable figures."""
        per_node = 1e6 / (self.bare_tps * self.nodes)
        verdict = "ok" if self.overhead_percent <= RUNTIME_OVERHEAD_GOAL else "over the goal"
        return [
            f"runtime [{self.variant}] {self.nodes}-node tree, {self.ticks} ticks, best round:",
            f"  bare py_trees : {self.bare_tps:9.1f} ticks/s  ({per_node:.2f} us per node tick;"
            " root.tick_once())",
            f"  BehaviourTree : {self.behaviour_tree_tps:9.1f} ticks/s  (py_trees' BehaviourTree.tick())",
            f"  + Snapshot    : {self.snapshot_tps:9.1f} ticks/s  (the same with py_trees'"
            " SnapshotVisitor, its own status tracking)",
            f"  armtree.run   : {self.armtree_tps:9.1f} ticks/s  (run log + status tracking on;"
            f" {self.changes_per_tick:.1f} status changes logged per tick)",
            f"  overhead      : {self.overhead_percent:+.1f} %  (goal <= "
            f"{RUNTIME_OVERHEAD_GOAL:g} %: {verdict})",
        ]


def _bare(ticks: int, churn: bool, whole_tree: bool = False, snapshot: bool = False) -> float:
    root = bench_tree(churn)
    tree = py_trees.trees.BehaviourTree(root)
    if snapshot:
        tree.add_visitor(py_trees.visitors.SnapshotVisitor())
    tree.setup()
    tick = tree.tick if whole_tree or snapshot else root.tick_once
    start = time.process_time()
    for _ in range(ticks):
        tick()
    return time.process_time() - start


def _armtree(ticks: int, churn: bool, log_dir: Path) -> tuple[float, int]:
    from armtree.loader.tree import Tree
    from armtree.runtime.runner import Run

    tree = Tree(name="bench", root=bench_tree(churn), source=None, tick_hz=1000)
    run = Run(tree, record=log_dir, max_ticks=ticks, handle_signals=False, stop_key=False)
    start = time.process_time()
    result = run.execute()
    elapsed = time.process_time() - start
    if result.ticks != ticks:
        raise RuntimeError(f"benchmark run stopped early: {result.message}")
    with (log_dir / "run.jsonl").open(encoding="utf-8") as log:
        changes = sum(1 for line in log if line.startswith('{"kind": "status"'))
    return elapsed, changes


def runtime_benchmark(
    ticks: int = 1000,
    rounds: int = 10,
    churn: bool = False,
    progress: Callable[[], None] | None = None,
) -> RuntimeFigures:
    """Measure bare py_trees against armtree's runtime on :func:`bench_tree` (see module doc)."""
    nodes = sum(1 for _ in bench_tree(churn).iterate())
    best_bare = best_armtree = best_bt = best_snap = float("inf")
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(rounds):
            best_bare = min(best_bare, _bare(ticks, churn))
            best_bt = min(best_bt, _bare(ticks, churn, whole_tree=True))
            best_snap = min(best_snap, _bare(ticks, churn, snapshot=True))
            elapsed, changes = _armtree(ticks, churn, Path(tmp) / str(r))
            best_armtree = min(best_armtree, elapsed)
            if progress is not None:
                progress()
    variant = "churn" if churn else "steady"
    return RuntimeFigures(
        variant,
        nodes,
        ticks,
        ticks / best_bare,
        ticks / best_armtree,
        ticks / best_bt,
        changes / ticks,
        ticks / best_snap,
    )


# ---------------------------------------------------------------------------
# armtree bench
# ---------------------------------------------------------------------------


def configure_bench(parser: argparse.ArgumentParser) -> None:
    """Options of ``armtree bench``."""
    parser.add_argument(
        "names",
        nargs="*",
        metavar="NAME",
        help="benchmarks to run (default: all); 'runtime' is built in, others are "
        "benchmarks/bench_NAME.py scripts",
    )
    parser.add_argument(
        "--dir", type=Path, default=Path("benchmarks"), help="folder of bench_*.py scripts"
    )
    parser.add_argument("--list", action="store_true", help="list the benchmarks and exit")
    parser.add_argument("--ticks", type=int, default=1000, help="ticks per round (runtime)")
    parser.add_argument("--rounds", type=int, default=10, help="rounds (runtime)")


def _scripts(folder: Path) -> dict[str, Path]:
    if not folder.is_dir():
        return {}
    return {p.stem.removeprefix("bench_"): p for p in sorted(folder.glob("bench_*.py"))}


def run_bench(args: argparse.Namespace) -> int:
    """``armtree bench``: run the chosen benchmarks with a progress bar; 0 if all ran."""
    from rich.console import Console
    from rich.progress import Progress

    from armtree.errors import ConfigError

    scripts = _scripts(args.dir)
    # The built-in runtime benchmark replaces the script that only wraps it.
    scripts.pop("runtime", None)
    available = ["runtime", *scripts]
    if args.list:
        for name in available:
            where = "built in" if name == "runtime" else str(scripts[name])
            print(f"{name}\t{where}")
        return 0
    chosen = args.names or available
    unknown = [n for n in chosen if n not in available]
    if unknown:
        raise ConfigError(f"unknown benchmark {unknown[0]!r}; choose from: {', '.join(available)}")
    console = Console()
    failed = 0
    reports: list[str] = []
    with Progress(console=console, transient=True) as bar:
        for name in chosen:
            if name == "runtime":
                task = bar.add_task("runtime", total=2 * args.rounds)
                for churn in (False, True):
                    figures = runtime_benchmark(
                        args.ticks,
                        args.rounds,
                        churn=churn,
                        # partial binds this benchmark's task now, not the loop's last one.
                        progress=functools.partial(bar.advance, task),
                    )
                    reports.extend(figures.lines())
                continue
            task = bar.add_task(name, total=None)
            proc = subprocess.run(
                [sys.executable, str(scripts[name])], capture_output=True, text=True, check=False
            )
            bar.update(task, total=1, completed=1)
            reports.append(f"{name} ({scripts[name]}):")
            reports.extend("  " + line for line in proc.stdout.splitlines())
            if proc.returncode != 0:
                failed += 1
                reports.append(f"  FAILED with exit code {proc.returncode}")
                reports.extend("  " + line for line in proc.stderr.splitlines()[-10:])
    for line in reports:
        console.print(line, highlight=False, markup=False, soft_wrap=True)
    return 1 if failed else 0
