"""Cost of an episode: runs with ``--dataset`` against the same runs without it.

    python benchmarks/bench_dataset.py [--tree load_ducky.yaml] [--rig sim_dobot] [--seeds 1-6]
        [--sweep-seeds 1-40] [--rounds 3]

Two ways a user makes episodes, each against its own peer measured in the same
session with the same seeds:

* ``run-tree TREE --seed N --quiet``, each seed run without and then with
  ``--dataset DIR --dataset-keep all`` (every run an episode: recording, encoding,
  appending to one growing dataset); the medians of the runs and of each pair's
  ratio, which a shared machine's load moves least;
* ``armtree sweep TREE --seeds A-B --workers 2``, against the same with
  ``--dataset DIR --dataset-keep all``, alternating, the best round of each
  (``--sweep-seeds``, default ``--seeds``: a long sweep spreads the sweep's own start
  and last append over more runs, as a user's sweep of a thousand seeds does).

Each line gives wall and CPU seconds per run (CPU: every process of the
configuration, children included). Then the cost of one append as the newest video
file grows, since an append rewrites that file: episodes of the first round's
dataset appended again and again into a fresh one. The machine's load average is
printed with the figures: on a shared machine they move by several per cent.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BIN = Path(sys.executable).parent


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed(commands: list[list[str]], work: Path) -> tuple[float, float]:
    """Wall and CPU seconds of running ``commands`` one after another."""
    cpu, started = _children_cpu(), time.monotonic()
    for command in commands:
        subprocess.run(
            command, cwd=work, check=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
    return time.monotonic() - started, _children_cpu() - cpu


def _dataset(folder: Path | None) -> list[str]:
    return [] if folder is None else ["--dataset", str(folder), "--dataset-keep", "all"]


def appends(work: Path, staged_from: Path, count: int) -> list[tuple[float, float, float]]:
    """(video MB before, wall s, CPU s) of ``count`` appends of one staged episode."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from armtree.plugins.dataset.episode import load
    from armtree.plugins.dataset.writer import DatasetWriter

    writer = DatasetWriter(work / "growing", None, "bench")
    out = []
    try:
        for _ in range(count):
            copy = work / "staged-copy"
            shutil.rmtree(copy, ignore_errors=True)
            shutil.copytree(staged_from, copy)
            episode = load(copy)
            videos = sorted((work / "growing").glob("videos/*/*/*.mp4"))
            size = videos[-1].stat().st_size / 1e6 if videos else 0.0  # the newest file
            usage = resource.getrusage(resource.RUSAGE_SELF)
            cpu, started = usage.ru_utime + usage.ru_stime, time.monotonic()
            writer.append([episode])
            usage = resource.getrusage(resource.RUSAGE_SELF)
            out.append((size, time.monotonic() - started, usage.ru_utime + usage.ru_stime - cpu))
    finally:
        writer.close()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tree", default="load_ducky.yaml")
    parser.add_argument("--rig", default="sim_dobot")
    parser.add_argument("--seeds", default="1-6")
    parser.add_argument("--sweep-seeds", default=None)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--appends", type=int, default=100)
    args = parser.parse_args()
    first, _, last = args.seeds.partition("-")
    seeds = range(int(first), int(last or first) + 1)
    sweep_seeds = args.sweep_seeds or args.seeds
    first, _, last = sweep_seeds.partition("-")
    n = int(last or first) - int(first) + 1
    best: dict[str, tuple[float, float]] = {}
    print(f"load average before: {os.getloadavg()[0]:.1f}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)

        def run_tree(folder: Path | None) -> list[list[str]]:
            return [
                [str(BIN / "run-tree"), args.tree, "--rig", args.rig, "--seed", str(s), "--quiet"]
                + _dataset(folder)
                for s in seeds
            ]

        def sweep(folder: Path | None, out: str) -> list[list[str]]:
            command = [str(BIN / "armtree"), "sweep", args.tree, "--rig", args.rig]
            command += ["--seeds", sweep_seeds, "--workers", "2", "--out", out, "--overwrite"]
            return [command + _dataset(folder)]

        # run-tree: each seed without, then with --dataset, so that each pair meets the
        # same load; medians of the runs and of the pairs' ratios.
        pairs: list[tuple[tuple[float, float], tuple[float, float]]] = []
        for round_ in range(args.rounds):
            for seed, (plain, recorded) in enumerate(
                zip(run_tree(None), run_tree(work / "ds-run"), strict=True), start=seeds[0]
            ):
                pairs.append((_timed([plain], work), _timed([recorded], work)))
                (w0, c0), (w1, c1) = pairs[-1]
                print(
                    f"round {round_ + 1} seed {seed}: run-tree {w0:.2f} s wall {c0:.2f} s CPU; "
                    f"--dataset {w1:.2f} s wall {c1:.2f} s CPU",
                    flush=True,
                )
        # The datasets grow from round to round, as a dataset that is appended to does.
        sweeps = {
            "sweep": sweep(None, "sweep-a"),
            "sweep --dataset": sweep(work / "ds-sweep", "sweep-b"),
        }
        for round_ in range(args.rounds):
            for name, commands in sweeps.items():
                wall, cpu = _timed(commands, work)
                if name not in best or wall < best[name][0]:
                    best[name] = (wall, cpu)
                print(
                    f"round {round_ + 1}: {name}: {wall / n:.2f} s wall, {cpu / n:.2f} s CPU per run",
                    flush=True,
                )
        print(f"load average after the runs: {os.getloadavg()[0]:.1f}")
        median = statistics.median
        print(
            f"run-tree, median of {len(pairs)} runs: {median(a[0] for a, _ in pairs):.2f} s wall, "
            f"{median(a[1] for a, _ in pairs):.2f} s CPU without; "
            f"{median(b[0] for _, b in pairs):.2f} s, {median(b[1] for _, b in pairs):.2f} s with "
            f"--dataset; median ratio of the pairs: wall "
            f"{100 * (median(b[0] / a[0] for a, b in pairs) - 1):+.1f} %, CPU "
            f"{100 * (median(b[1] / a[1] for a, b in pairs) - 1):+.1f} %"
        )
        (w0, c0), (w1, c1) = best["sweep"], best["sweep --dataset"]
        print(
            f"sweep, best of {args.rounds}: per run {w0 / n:.2f} s wall, {c0 / n:.2f} s CPU without; "
            f"{w1 / n:.2f} s, {c1 / n:.2f} s with --dataset: wall {100 * (w1 / w0 - 1):+.1f} %, "
            f"CPU {100 * (c1 / c0 - 1):+.1f} %"
        )
        info = json.loads((work / "ds-sweep" / "meta" / "info.json").read_text())
        print(
            f"the sweep's dataset: {info['total_episodes']} episodes, {info['total_frames']} frames"
        )
        # an episode to append again and again: the last seed's, staged by a sweep run
        staged = work / "one-run"
        one_seed = [str(BIN / "armtree"), "sweep", args.tree, "--rig", args.rig, "--workers", "1"]
        one_seed += ["--seeds", str(seeds[-1]), "--out", "sweep-c", "--overwrite"]
        one_seed += ["--dataset", str(staged / "ds"), "--dataset-keep", "all"]
        _timed([one_seed], work)
        episode = _staged_episode(work, staged / "ds", seeds[-1])
        rows = appends(work, episode, args.appends)
        print("appends as the newest video file grows (MB before: wall, CPU):")
        for size, wall, cpu in rows[:: max(1, len(rows) // 10)] + rows[-1:]:
            print(f"  {size:6.1f} MB: {wall:.3f} s wall, {cpu:.3f} s CPU")
    print(f"load average at the end: {os.getloadavg()[0]:.1f}")


def _staged_episode(work: Path, dataset: Path, seed: int) -> Path:
    """A staged episode made from the one-seed dataset: its video and arrays."""
    import numpy as np
    import pyarrow.parquet as pq

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from armtree.plugins.dataset import stats
    from armtree.plugins.dataset.episode import Episode

    info = json.loads((dataset / "meta" / "info.json").read_text())
    data = pq.read_table(dataset / "data" / "chunk-000" / "file-000.parquet")
    names = info["features"]["observation.state"]["names"]
    saved = json.loads((dataset / "meta" / "stats.json").read_text())
    video = work / "episode.mp4"
    shutil.copy(dataset / "videos/observation.images.camera/chunk-000/file-000.mp4", video)
    episode = Episode(
        fps=info["fps"],
        task="bench",
        robot_type=info["robot_type"],
        joints=[n[: -len(".pos")] for n in names[:-2]],
        state=np.stack(data.column("observation.state").to_numpy(zero_copy_only=False)),
        action=np.stack(data.column("action").to_numpy(zero_copy_only=False)),
        video=video,
        image_shape=tuple(info["features"]["observation.images.camera"]["shape"]),
        image_stats=stats.from_json({"i": saved["observation.images.camera"]})["i"],
        tags={"seed": seed},
    )
    return episode.stage(work / "staged")


if __name__ == "__main__":
    main()
