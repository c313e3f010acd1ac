"""Cost of an episode: runs with ``--dataset`` against the same runs without it.

    python benchmarks/bench_dataset.py [--tree load_ducky.yaml] [--rig sim_dobot] [--seeds 1-6] [--rounds 2]

Two ways a user makes episodes, each against its own peer measured in the same
session with the same seeds (configurations alternate within each round, the best
round of each is kept, on wall time):

* ``run-tree TREE --seed N --quiet`` one seed after another, against the same with
  ``--dataset DIR`` appending to one growing dataset (``--dataset-keep all``, so
  every run is an episode: recording, encoding, appending);
* ``armtree sweep TREE --seeds A-B --workers 2``, against the same with
  ``--dataset DIR --dataset-keep all``.

Printed: wall seconds per run for each, the added share (goal: under 25 %), and the
machine's load average, since a shared machine moves the figures by several per cent.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BIN = Path(sys.executable).parent


def _run_tree(tree: str, rig: str, seeds: range, work: Path, dataset: Path | None) -> float:
    started = time.monotonic()
    for seed in seeds:
        extra = [] if dataset is None else ["--dataset", str(dataset), "--dataset-keep", "all"]
        subprocess.run(
            [str(BIN / "run-tree"), tree, "--rig", rig, "--seed", str(seed), "--quiet", *extra],
            cwd=work,
            check=False,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    return time.monotonic() - started


def _sweep(tree: str, rig: str, seeds: str, work: Path, dataset: Path | None) -> float:
    extra = [] if dataset is None else ["--dataset", str(dataset), "--dataset-keep", "all"]
    command = [str(BIN / "armtree"), "sweep", tree, "--rig", rig, "--seeds", seeds]
    command += ["--workers", "2", "--out", str(work / "sweep"), "--overwrite", *extra]
    started = time.monotonic()
    subprocess.run(
        command, cwd=work, check=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    return time.monotonic() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tree", default="load_ducky.yaml")
    parser.add_argument("--rig", default="sim_dobot")
    parser.add_argument("--seeds", default="1-6")
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    first, _, last = args.seeds.partition("-")
    seeds = range(int(first), int(last or first) + 1)
    n = len(seeds)
    best: dict[str, float] = {}
    frames = 0
    print(f"load average before: {os.getloadavg()[0]:.1f}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for round_ in range(args.rounds):
            configs = {
                "run-tree": lambda: _run_tree(args.tree, args.rig, seeds, work, None),
                "run-tree --dataset": lambda: _run_tree(
                    args.tree, args.rig, seeds, work, work / "ds-run"
                ),
                "sweep": lambda: _sweep(args.tree, args.rig, args.seeds, work, None),
                "sweep --dataset": lambda: _sweep(
                    args.tree, args.rig, args.seeds, work, work / "ds-sweep"
                ),
            }
            # Later rounds append to the datasets the earlier ones made, as a growing
            # dataset is appended to.
            for name, measure in configs.items():
                seconds = measure()
                best[name] = min(best.get(name, seconds), seconds)
                print(f"round {round_ + 1}: {name}: {seconds / n:.2f} s per run", flush=True)
        info = work / "ds-sweep" / "meta" / "info.json"
        if info.exists():
            frames = json.loads(info.read_text())["total_frames"]
    print(f"load average after: {os.getloadavg()[0]:.1f}")
    print(f"episodes of the sweep's dataset: {frames} frames in all")
    for base in ("run-tree", "sweep"):
        plain, with_dataset = best[base] / n, best[f"{base} --dataset"] / n
        print(
            f"{base}: {plain:.2f} s per run without, {with_dataset:.2f} s with --dataset: "
            f"+{with_dataset - plain:.2f} s, {100 * (with_dataset / plain - 1):+.1f} %"
        )


if __name__ == "__main__":
    main()
