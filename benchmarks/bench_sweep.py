"""Sweep throughput: runs per minute with 1 and 2 local workers, the sweep against a shell
loop of the same runs, and a 2-worker Dask LocalCluster against the 2-worker local pool.

    python benchmarks/bench_sweep.py [--tree load_ducky.yaml] [--rig sim_dobot] [--seeds 1-8] [--rounds 2]

Every configuration runs the same seeds (each run in a fresh process, logs only,
no videos); the configurations alternate within each round and the best round of
each is kept, on wall time (what a user waits for). The shell loop is
``run-tree TREE --rig P --seed N --quiet`` one seed after another, as a user would
write it. The machine's load average is printed with the figures: on a shared
machine they move by several per cent from one run of the script to the next.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _sweep(tree: str, rig: str, seeds: str, out: Path, extra: list[str]) -> float:
    command = [
        sys.executable,
        "-m",
        "armtree.cli",
        "sweep",
        tree,
        "--rig",
        rig,
        "--seeds",
        seeds,
        "--out",
        str(out),
        "--overwrite",
        *extra,
    ]
    started = time.monotonic()
    subprocess.run(command, check=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.monotonic() - started


def _loop(tree: str, rig: str, seeds: range, work: Path) -> float:
    run_tree = Path(sys.executable).with_name("run-tree")
    started = time.monotonic()
    for seed in seeds:
        subprocess.run(
            [str(run_tree), tree, "--rig", rig, "--seed", str(seed), "--quiet"],
            cwd=work,
            check=False,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    return time.monotonic() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tree", default="load_ducky.yaml")
    parser.add_argument("--rig", default="sim_dobot")
    parser.add_argument("--seeds", default="1-8")
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    first, _, last = args.seeds.partition("-")
    seeds = range(int(first), int(last or first) + 1)
    n = len(seeds)
    best: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        from distributed import LocalCluster

        with LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster:
            configs = {
                "shell loop": lambda: _loop(args.tree, args.rig, seeds, work),
                "sweep, 1 worker": lambda: _sweep(
                    args.tree, args.rig, args.seeds, work / "s1", ["--workers", "1"]
                ),
                "sweep, 2 workers": lambda: _sweep(
                    args.tree, args.rig, args.seeds, work / "s2", ["--workers", "2"]
                ),
                "sweep, Dask LocalCluster (2 worker processes)": lambda: _sweep(
                    args.tree,
                    args.rig,
                    args.seeds,
                    work / "sd",
                    ["--scheduler", cluster.scheduler_address],
                ),
            }
            for r in range(args.rounds):
                for name, measure in configs.items():
                    seconds = measure()
                    best[name] = min(best.get(name, float("inf")), seconds)
                    print(f"round {r + 1}: {name}: {seconds:.1f} s", flush=True)
    load = os.getloadavg()
    print(
        f"\n{args.tree} on {args.rig}, seeds {args.seeds} ({n} runs), best of {args.rounds} rounds, wall time;"
    )
    print(f"load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} on {os.cpu_count()} CPUs")
    for name, seconds in best.items():
        print(f"  {name:48s} {seconds:7.1f} s  {n / seconds * 60:6.2f} runs/min")
    loop, one, two, dask = (best[k] for k in configs)
    print(
        f"  sweep (1 worker) against the shell loop: {100 * (one - loop) / loop:+.1f} % time (goal: within +10 %)"
    )
    print(f"  2 workers against 1: {one / two:.2f}x the runs per minute")
    print(
        f"  Dask LocalCluster against the local pool (2 workers each): {100 * (dask - two) / two:+.1f} % time (goal: within 15 %)"
    )


if __name__ == "__main__":
    main()
