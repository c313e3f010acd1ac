"""Sweeps of load_ducky on two installs of armtree: runs a minute, median run, cost of each part.

For each rig and round it runs ``armtree sweep load_ducky.yaml`` once with each
install (``--base-python``, an interpreter whose armtree is the code before, and
``--new-python``, default this one), alternating which goes first, and reads each
sweep's ``sweep.json``: runs a minute (runs over the sweep's wall time, the
forker's start included, as a user sees it) and the median run's wall time and
simulated over wall time (x real time). Then, per install, it times the parts of
forked runs of a few seeds (``--part-seeds``) with timers wrapped around them:
making the plugin manager, loading the tree, building the renderer (table texture and
noise bank), rendering frames, detecting markers, the emulator's step (the serial
exchange: the driver's thread answers while it waits), the world's step. A part's
cost is the process's CPU time (every thread) while it runs, which the machine's
load moves far less than wall time. Every figure is printed for both installs
and as the ratio new / base measured in the same run, since on a shared machine
only the ratios hold from one minute to the next; the load average is printed at
the start and the end.

Making a base install from a git ref, beside this checkout's venv::

    git archive main | tar -x -C /tmp/base
    python3.11 -m venv /tmp/basevenv
    echo "$VIRTUAL_ENV/lib/python3.11/site-packages" > /tmp/basevenv/lib/python3.11/site-packages/deps.pth
    /tmp/basevenv/bin/pip install -q --no-deps --no-build-isolation -e /tmp/base
    python benchmarks/sweep_speed_ab.py --base-python /tmp/basevenv/bin/python \\
        --seeds 9101-9130 --workers 2 --rounds 1
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

RIGS = ["sim_dobot", "sim_vicra", "sim_magician", "sim_dh"]

#: Parts timed in forked runs: label -> (module, class or "", function).
PARTS = {
    "plugin manager": ("armtree.hooks.plugin_manager", "", "make_plugin_manager"),
    "load tree": ("armtree.loader.tree_loader", "", "load_tree"),
    "renderer build": ("armtree.plugins.sim.renderer", "Renderer", "__init__"),
    "render": ("armtree.plugins.sim.renderer", "Renderer", "render"),
    "detect": ("armtree.plugins.trackers.aruco", "ArucoTracker", "detect"),
    "emulator step": ("armtree.plugins.arms.common.pty_emulator", "PtyEmulator", "step"),
    "world step": ("armtree.plugins.sim.world", "World", "step"),
}


def sweep(python: str, rig: str, seeds: str, workers: int, out: Path) -> dict:
    """One ``armtree sweep`` with ``python``'s install; its runs a minute and median run."""
    cmd = [python, "-c", "import sys; from armtree.cli.console import armtree; sys.exit(armtree())"]
    cmd += ["sweep", "load_ducky.yaml", "--seeds", seeds, "--rig", rig]
    cmd += ["--workers", str(workers), "--out", str(out), "--overwrite"]
    subprocess.run(cmd, capture_output=True, check=False)
    report = json.loads((out / "sweep.json").read_text())
    runs = report["runs"]
    wall = statistics.median(r["wall_seconds"] for r in runs)
    sim = statistics.median(r["seconds"] for r in runs)
    return {
        "runs_per_min": 60 * len(runs) / report["sweep"]["wall_seconds"],
        "median_wall": wall,
        "x_real_time": sim / wall,
        "successes": report["summary"]["successes"],
        "runs": len(runs),
    }


#: CPU seconds of each part in this process's run (a forked child's own copy).
SPENT: dict[str, float] = {}


def _timed(owner, name: str, label: str) -> None:
    inner = getattr(owner, name)

    def timed(*args, **kwargs):
        start = time.process_time()
        try:
            return inner(*args, **kwargs)
        finally:
            SPENT[label] = SPENT.get(label, 0.0) + time.process_time() - start

    setattr(owner, name, timed)


def _one_run(rig: str, seed: int) -> dict[str, float]:
    """In a forked child: run one seed as a sweep's run; the CPU seconds of each part."""
    from armtree.cli.sweep.task import RunTask, run_task

    with tempfile.TemporaryDirectory() as runs:
        start = time.process_time()
        outcome, _ = run_task(RunTask(tree="load_ducky.yaml", seed=seed, run_dir=runs, rig=rig))
        SPENT["whole run"] = time.process_time() - start
    SPENT["simulated"] = outcome["seconds"]
    return SPENT


def child_parts(rig: str, seeds: list[int]) -> None:
    """In a child interpreter: time the parts of forked runs; print one JSON line per seed."""
    import importlib

    from armtree.hooks.plugin_manager import get_plugin_manager

    get_plugin_manager().registry  # noqa: B018 - imports every plugin, as the sweep's forker does
    for label, (module, cls, name) in PARTS.items():
        try:
            owner = importlib.import_module(module)
            _timed(getattr(owner, cls) if cls else owner, name, label)
        except (ImportError, AttributeError):
            pass  # the part does not exist in this install: reported as missing
    fork = multiprocessing.get_context("fork")
    for seed in seeds:
        # A pool per run: a fresh forked process for each, as the sweep's forker gives.
        with ProcessPoolExecutor(1, mp_context=fork) as pool:
            print(json.dumps(pool.submit(_one_run, rig, seed).result()), flush=True)


def parts(python: str, rig: str, seeds: str) -> dict[str, float]:
    """Median CPU seconds per run of each part, in forked runs of ``seeds`` on ``python``'s install."""
    cmd = [python, __file__, "--child-rig", rig, "--part-seeds", seeds]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    rows = [json.loads(line) for line in out.splitlines() if line.startswith("{")]
    labels = ["whole run", *PARTS]
    return {k: statistics.median(r.get(k, float("nan")) for r in rows) for k in labels}


def _seed_list(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base-python", help="interpreter of the install before (required)")
    parser.add_argument("--new-python", default=sys.executable)
    parser.add_argument("--rigs", nargs="+", default=RIGS)
    parser.add_argument("--seeds", default="9101-9130", help="seeds of each sweep")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=1, help="sweeps per rig and install")
    parser.add_argument("--part-seeds", default="9101-9103", help="seeds whose parts are timed")
    parser.add_argument("--child-rig", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child_rig:
        child_parts(args.child_rig, _seed_list(args.part_seeds))
        return
    if not args.base_python:
        parser.error("--base-python PYTHON is required")
    print(f"load average {os.getloadavg()[0]:.2f} at the start")
    installs = [("base", args.base_python), ("new", args.new_python)]
    with tempfile.TemporaryDirectory() as tmp:
        for i, rig in enumerate(args.rigs):
            got: dict[str, list[dict]] = {"base": [], "new": []}
            for k in range(args.rounds):
                order = installs if (i + k) % 2 == 0 else installs[::-1]
                for name, python in order:
                    got[name].append(sweep(python, rig, args.seeds, args.workers, Path(tmp) / name))
            row = {}
            for name in ("base", "new"):
                s = got[name]
                row[name] = {key: statistics.median(x[key] for x in s) for key in s[0]}
                r = row[name]
                print(
                    f"{rig} {name}: {r['runs_per_min']:.1f} runs/min, median run "
                    f"{r['median_wall']:.3f} s wall ({r['x_real_time']:.1f}x real time), "
                    f"{r['successes']:.0f} of {r['runs']:.0f} succeeded"
                )
            b, n = row["base"], row["new"]
            print(
                f"{rig} new/base: runs/min {n['runs_per_min'] / b['runs_per_min']:.2f}x, "
                f"median run wall {n['median_wall'] / b['median_wall']:.2f}x"
            )
            spent = {name: parts(python, rig, args.part_seeds) for name, python in installs}
            whole = {name: spent[name]["whole run"] for name in spent}
            for label in ["whole run", *PARTS]:
                b, n = spent["base"][label], spent["new"][label]
                print(
                    f"  {label:15s} base {b:6.3f} s ({b / whole['base']:5.1%})  "
                    f"new {n:6.3f} s ({n / whole['new']:5.1%})  new/base {n / b:.2f}x"
                )
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
