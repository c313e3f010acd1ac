"""``armtree sweep TREE --seeds A-B ...``: one tree over many seeds, in parallel, then a report.

Each seed runs in a process of its own (no blackboard, plugin manager, emulator
or file descriptor outlives its run), on this machine (``--workers N``) or on a
Dask cluster (``--scheduler tcp://HOST:PORT``). A rich progress bar shows done,
failed, the rate and the time left; ``DIR/report.md`` and ``DIR/sweep.json``
hold what was found. Ctrl-C (or SIGTERM) halts the runs under way, writes the
report of what finished and exits 130; a run past ``--run-timeout`` wall
seconds is killed and counted as failed; a run whose process dies is reported
and run once more.

Exit codes: 0 every run succeeded, 1 some did not, 2 bad input (seeds, address,
tree, an output folder holding another sweep, no usable Dask worker), 3 the
scheduler does not answer, 130 interrupted.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import shlex
import signal
import sys
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, wait
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

from armtree.api.output_paths import output_folder
from armtree.api.sweep import Sweep
from armtree.cli.options import add_tree_arguments
from armtree.errors import ConfigError
from armtree.hooks.plugin_manager import PluginManager
from armtree.runtime.interrupts import EXIT_INTERRUPTED

from .hooks import SweepHooks, add_plugin_options, plugin_settings
from .options import check_address, parse_seeds
from .report import summarise, write_report
from .task import DIED, Outcome, RunTask

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_UNREACHABLE = 0, 1, 2, 3
#: Files that mark a folder as holding a sweep.
SWEEP_FILES = ("sweep.json", "report.md", "runs")
#: Wall seconds between the reports a sweep writes while it runs.
CHECKPOINT_S = 300.0


def configure(parser: argparse.ArgumentParser, manager: PluginManager | None = None) -> None:
    """The sweep's options: TREE, --rig and --set as ``armtree check`` takes them, its own,
    and those the plugins of ``manager`` add (``armtree_sweep_options``)."""
    add_tree_arguments(parser)
    parser.add_argument("--seeds", required=True, metavar="A-B", help="seeds to run, e.g. 1-1000")
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="runs at a time on this machine (default: its CPU count)",
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on the Dask cluster of this scheduler (tcp://HOST:PORT) instead",
    )
    parser.add_argument(
        "--out", metavar="DIR", help="report folder (default sweeps/<tree>-<time>/)"
    )
    parser.add_argument("--overwrite", action="store_true", help="replace a sweep already in --out")
    parser.add_argument(
        "--run-timeout",
        type=float,
        default=600.0,
        metavar="SECONDS",
        help="kill a run after this much wall time and count it failed (default 600)",
    )
    parser.add_argument(
        "--timeout",
        type=float,
        metavar="SECONDS",
        help="each run fails after SECONDS on its own clock (as run-tree --timeout: 600 on "
        "the simulation unless given)",
    )
    add_plugin_options(parser, manager)


def _reference(value: str | None) -> str | None:
    """A file given on the command line as an absolute path (workers elsewhere see the
    same path on a shared folder); a shipped tree or profile by its name."""
    if value is None:
        return None
    path = Path(value)
    for candidate in (path, path.with_suffix(".yaml")):
        if candidate.is_file():
            return str(candidate.resolve())
    return value


def _out_dir(value: str | None, tree_name: str, overwrite: bool) -> Path:
    if value is None:
        return Path("sweeps") / f"{tree_name}-{time.strftime('%Y%m%d-%H%M%S')}"
    return output_folder(value, "--out", SWEEP_FILES, overwrite, what="sweep")


@contextlib.contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM stops a sweep as Ctrl-C does."""

    def handler(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def drive(
    pool: Any, tasks: Sequence[RunTask], done: Callable[[Outcome], None], say: Callable[[str], None]
) -> tuple[list[Outcome], bool]:
    """Run every task on ``pool``; the outcomes and whether the sweep was interrupted.

    A run whose process died is reported and run once more; its second outcome counts.
    """
    queue = deque(tasks)
    inflight: dict[Future, RunTask] = {}
    outcomes: list[Outcome] = []
    try:
        while queue or inflight:
            while queue and len(inflight) < pool.capacity:
                task = queue.popleft()
                inflight[pool.submit(task)] = task
            finished, _ = wait(list(inflight), timeout=0.25, return_when=FIRST_COMPLETED)
            for future in finished:
                task = inflight.pop(future)
                outcome = future.result()
                if outcome["status"] == DIED and task.attempt == 1:
                    say(
                        f"seed {task.seed}: {outcome['reason']} on {outcome.get('worker', 'a worker')}; running it once more"
                    )
                    queue.appendleft(task.retry())
                    continue
                outcomes.append(outcome)
                done(outcome)
    except KeyboardInterrupt:
        say("interrupted: halting the runs under way; the report keeps what finished")
        with contextlib.suppress(Exception):
            pool.stop()
        return outcomes, True
    return outcomes, False


class SweepCommand:
    """``armtree sweep``: run a tree over many seeds and report the success rate."""

    help = "run a tree over many seeds in parallel (local processes or a Dask cluster) and report"

    def configure(
        self, parser: argparse.ArgumentParser, manager: PluginManager | None = None
    ) -> None:
        """Add the sweep's options, and those of ``manager``'s plugins."""
        configure(parser, manager)

    def run(self, args: argparse.Namespace) -> int:
        """Validate, run every seed, write the report; the exit code."""
        return run_sweep(args, Console(), sys.argv)


def run_sweep(args: argparse.Namespace, console: Console, argv: Sequence[str]) -> int:
    """The sweep the options describe; prints a summary and returns the exit code."""
    from armtree.hooks.plugin_manager import get_plugin_manager
    from armtree.loader.tree_loader import load_tree

    seeds = parse_seeds(args.seeds)
    if args.workers is not None and args.workers < 1:
        raise ConfigError("give at least 1", file=f"--workers {args.workers}")
    if args.run_timeout is not None and not 0 < args.run_timeout < float("inf"):
        raise ConfigError(
            "give a positive number of seconds (a finite one: the wall time a run may take)",
            file=f"--run-timeout {args.run_timeout:g}",
        )
    if args.timeout is not None and not args.timeout > 0:
        raise ConfigError(
            "give a positive number of seconds (inf: no limit)", file=f"--timeout {args.timeout:g}"
        )
    if args.scheduler is not None:
        check_address(args.scheduler)
    manager = getattr(args, "manager", None) or get_plugin_manager(
        getattr(args, "plugin", None) or ()
    )
    tree = load_tree(args.tree, rig=args.rig, overrides=args.overrides, manager=manager)
    out = _out_dir(args.out, tree.name, args.overwrite).resolve()
    sweep = Sweep(tree=tree, seeds=seeds, out=out, settings=plugin_settings(args))
    hooks = SweepHooks(manager)
    try:
        hooks.started(sweep)
        return _run(args, console, argv, sweep, hooks, manager)
    finally:
        sweep.close()


def _run(
    args: argparse.Namespace,
    console: Console,
    argv: Sequence[str],
    plugged: Sweep,
    hooks: SweepHooks,
    manager: PluginManager,
) -> int:
    tree, seeds, out = plugged.tree, plugged.seeds, plugged.out
    profile = getattr(tree, "profile", None)
    plugins = tuple(getattr(args, "plugin", None) or ())
    blocked = tuple(getattr(manager, "blocked", ()) or ())
    template = dict(
        tree=_reference(args.tree) or args.tree,
        rig=_reference(args.rig),
        overrides=tuple(args.overrides),
        plugins=plugins,
        blocked=blocked,
        timeout=args.timeout,
        settings=dict(plugged.settings),
        preload=tuple(plugged.preload),
    )
    tasks = [RunTask(seed=s, run_dir=str(out / "runs" / f"seed-{s}"), **template) for s in seeds]
    workers = args.workers or os.cpu_count() or 1
    if args.scheduler:
        from .cluster import DaskPool, SchedulerUnreachable

        try:
            pool: Any = DaskPool(args.scheduler, args.run_timeout)
        except SchedulerUnreachable as exc:
            console.print(f"[red]error:[/red] {exc}", soft_wrap=True)
            return EXIT_UNREACHABLE
        bad = pool.preflight(tasks[0])
        for worker, problem in sorted(bad.items()):
            console.print(
                f"[yellow]worker {worker}[/yellow]: {problem}; it gets no seeds", soft_wrap=True
            )
        if not pool.good:
            pool.close()
            console.print("[red]error:[/red] no Dask worker can run this tree", soft_wrap=True)
            return EXIT_USAGE
    else:
        out.mkdir(parents=True, exist_ok=True)
        pool = LocalPoolFactory(workers, args.run_timeout, out / "forker.log")
    sweep = {
        "tree": template["tree"],
        "tree_name": tree.name,
        "rig": template["rig"] or (getattr(profile, "name", None)),
        "overrides": list(args.overrides),
        "plugins": list(plugins),
        "timeout": args.timeout,
        "seeds": [seeds[0], seeds[-1]],
        "requested": len(seeds),
        "scheduler": args.scheduler,
        "workers": None if args.scheduler else workers,
        "run_timeout": args.run_timeout,
        "command": shlex.join(["armtree", *argv[1:]]) if argv else "armtree sweep",
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "bad_workers": dict(getattr(pool, "bad", {}) or {}),
    }
    started = time.monotonic()

    def checkpoint(done: list[Outcome]) -> None:
        partial = {**sweep, "wall_seconds": time.monotonic() - started, "in_progress": True}
        partial["where"] = pool.describe()
        write_report(out, summarise(partial, done))

    def finished(outcome: Outcome) -> None:
        hooks.notify("armtree_sweep_run_finished", sweep=plugged, outcome=outcome)

    outcomes, interrupted = _with_progress(pool, tasks, console, tree.name, checkpoint, finished)
    hooks.notify(
        "armtree_sweep_finished", sweep=plugged, outcomes=list(outcomes), interrupted=interrupted
    )
    sweep["wall_seconds"] = time.monotonic() - started
    sweep["interrupted"] = interrupted
    sweep["where"] = pool.describe()
    report = summarise(sweep, outcomes)
    write_report(out, report)
    _print_summary(console, report, out)
    if interrupted:
        return EXIT_INTERRUPTED
    return EXIT_OK if report["summary"]["successes"] == len(outcomes) else EXIT_FAILED


def LocalPoolFactory(workers: int, run_timeout: float | None, log: Path) -> Any:  # noqa: N802
    """The local pool (imported late: it starts a process)."""
    from .pool import LocalPool

    return LocalPool(workers, run_timeout, log)


def _with_progress(
    pool: Any,
    tasks: Sequence[RunTask],
    console: Console,
    name: str,
    checkpoint: Callable[[list[Outcome]], None],
    finished: Callable[[Outcome], None] = lambda outcome: None,
) -> tuple[list[Outcome], bool]:
    failed = 0
    started = time.monotonic()
    ended: list[Outcome] = []
    last_checkpoint = started
    columns = (
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("[red]failed {task.fields[failed]}[/red]"),
        TextColumn("{task.fields[rate]}"),
        TimeRemainingColumn(),
    )
    with _sigterm_as_interrupt(), Progress(*columns, console=console, transient=False) as progress:
        bar = progress.add_task(f"sweep {name}", total=len(tasks), failed=0, rate="")
        try:
            pool.start()
        except KeyboardInterrupt:
            pool.close()
            return [], True

        def done(outcome: Outcome) -> None:
            nonlocal failed, last_checkpoint
            failed += outcome["verdict"] != "success"
            ended.append(outcome)
            finished(outcome)
            now = time.monotonic()
            rate = len(ended) / max(1e-9, now - started) * 60
            progress.update(bar, advance=1, failed=failed, rate=f"{rate:.1f} runs/min")
            if now - last_checkpoint >= CHECKPOINT_S:
                # A long sweep that is killed outright still leaves a report of what finished.
                last_checkpoint = now
                with contextlib.suppress(Exception):
                    checkpoint(list(ended))

        try:
            return drive(
                pool, tasks, done, lambda text: progress.console.print(text, soft_wrap=True)
            )
        finally:
            with contextlib.suppress(Exception):
                pool.close()


def _print_summary(console: Console, report: dict[str, Any], out: Path) -> None:
    s = report["summary"]
    if s["runs"]:
        low, high = s["wilson95"]
        console.print(
            f"success rate {100 * s['success_rate']:.1f} % ({s['successes']} of {s['runs']}), "
            f"95 % interval {100 * low:.1f}-{100 * high:.1f} %; false successes {s['false_successes']}, "
            f"false failures {s['false_failures']}",
            soft_wrap=True,
        )
    for r in report["reasons"][:3]:
        console.print(f"  {r['runs']} x {r['example']} (e.g. seed {r['seeds'][0]})", soft_wrap=True)
    console.print(f"report: {out / 'report.md'}", soft_wrap=True)
