"""load_ducky over many seeds and rigs: success, false successes, collisions, time per run.

Each run is judged by the simulated world's ground truth (``world.score()``),
never by the tree's own status alone:

* success: the tree ended SUCCESS, the ducky is on a Duckybot, nothing collided,
  nothing is held or fell off the table;
* false success: the tree ended SUCCESS but the world disagrees;
* the failure reason: the run's message (the failed node and its feedback).

Per rig it prints the success rate, false successes, runs with collisions,
the median simulated, wall and CPU seconds per run and the speed-up over real
time (simulated / wall), and the commonest failure reasons. Runs go to a process
pool (``--workers``); every run's record is appended to ``--out``/runs.jsonl.

Usage::

    python benchmarks/sweep_load_ducky.py --rigs sim_dobot sim_vicra --seeds 0-199 \\
        [--faults] [--workers 2] [--out DIR] [--set KEY=VALUE ...]

``--faults`` adds missed steps (``world.faults.missed_steps``, 0.1 slips a second
of up to 2 degrees while the arm moves) and 20 % dropped camera frames, in the
nominal world (seed 0) and in the randomised ones (``world.randomize``, whose own
draws of slips and drops would otherwise replace them).
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import statistics
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

FAULTS = (
    "world.faults.missed_steps={rate_per_s: 0.1, max_amount: 2.0}",
    "camera.drop_rate=0.2",
    # a randomised world (seed > 0) draws its own slips and drops: fix those draws too
    "world.randomize.faults.missed_steps={rate_per_s: 0.1, max_amount: 2.0}",
    "world.randomize.camera.drop_rate=0.2",
)


def parse_seeds(text: str) -> list[int]:
    """``A-B`` (inclusive) or ``A,B,C``."""
    if "-" in text:
        lo, hi = (int(v) for v in text.split("-", 1))
        return list(range(lo, hi + 1))
    return [int(v) for v in text.split(",")]


def one_run(tree: str, rig: str, seed: int, overrides: tuple[str, ...]) -> dict[str, Any]:
    """Run ``tree`` on ``rig`` with ``seed``; the record the summary is made of."""
    from armtree.loader.tree_loader import load_tree
    from armtree.plugins.sim.rig_world import sim_world
    from armtree.runtime.runner import Run

    wall0, cpu0 = time.perf_counter(), time.process_time()
    record: dict[str, Any] = {"rig": rig, "seed": seed}
    try:
        loaded = load_tree(tree, rig=rig, overrides=list(overrides))
        run = Run(loaded, None, seed=seed, record=False, max_ticks=40000, quiet=True)
        result = run.execute()
        score = sim_world(run).score()
    except Exception as exc:  # noqa: BLE001 - a crash is a failed run with its reason
        record.update(status="CRASH", ok=False, false_success=False, message=repr(exc)[:300])
        return record
    loaded_ok = bool(score["ducky_on_duckybot"])
    clean = score["collision_count"] == 0 and score["held"] is None
    clean = clean and not score["fell_off_table"]
    world_ok = loaded_ok and clean
    record.update(
        status=result.status,
        ok=result.status == "SUCCESS" and world_ok,
        false_success=result.status == "SUCCESS" and not world_ok,
        loaded=loaded_ok,
        collisions=score["collision_count"],
        collided_with=sorted({c["other"] for c in score["collisions"]}),
        held=score["held"],
        in_bin=score["in_bin"],
        sim_s=result.seconds,
        wall_s=time.perf_counter() - wall0,
        cpu_s=time.process_time() - cpu0,
        message=(result.message or "")[:300],
    )
    return record


def reason(record: dict[str, Any]) -> str:
    """A failure's reason with its numbers taken out, so alike failures count together."""
    import re

    text = record.get("message") or ""
    if record.get("false_success"):
        text = f"false success: loaded={record.get('loaded')} collisions={record.get('collisions')}"
    elif not text and record.get("collisions"):
        text = f"collision with {', '.join(record.get('collided_with') or [])}"
    text = text.split("): ", 1)[-1] if "): " in text else text
    return re.sub(r"-?\d+(\.\d+)?", "#", text)[:160]


def summarise(records: list[dict[str, Any]]) -> str:
    """One block per rig: rates, medians, top failure reasons."""
    lines = []
    by_rig: dict[str, list[dict[str, Any]]] = collections.defaultdict(list)
    for r in records:
        by_rig[r["rig"]].append(r)
    for rig, runs in sorted(by_rig.items()):
        n = len(runs)
        ok = sum(r["ok"] for r in runs)
        false = sum(r.get("false_success", False) for r in runs)
        coll = sum(1 for r in runs if r.get("collisions"))
        done = [r for r in runs if "sim_s" in r]
        sim = statistics.median(r["sim_s"] for r in done) if done else float("nan")
        wall = statistics.median(r["wall_s"] for r in done) if done else float("nan")
        cpu = statistics.median(r["cpu_s"] for r in done) if done else float("nan")
        speed = statistics.median(r["sim_s"] / r["wall_s"] for r in done) if done else 0.0
        lines.append(
            f"{rig}: {ok}/{n} = {100.0 * ok / n:.1f} % success, {false} false successes, "
            f"{coll} runs with collisions; median {sim:.1f} s simulated, {wall:.2f} s wall "
            f"({speed:.1f}x real time), {cpu:.2f} s CPU"
        )
        reasons = collections.Counter(reason(r) for r in runs if not r["ok"])
        for why, count in reasons.most_common(5):
            lines.append(f"    {count:4d} x {why}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tree", default="load_ducky.yaml")
    parser.add_argument("--rigs", nargs="+", default=["sim_dobot", "sim_vicra"])
    parser.add_argument("--seeds", default="0-49")
    parser.add_argument(
        "--faults", action="store_true", help="missed steps and 20 %% dropped frames"
    )
    parser.add_argument("--set", dest="overrides", action="append", default=[])
    parser.add_argument("--workers", type=int, default=max(1, (os.cpu_count() or 2) // 2))
    parser.add_argument("--out", default="runs/sweep")
    args = parser.parse_args()

    overrides = tuple(args.overrides) + (FAULTS if args.faults else ())
    jobs = [(rig, seed) for rig in args.rigs for seed in parse_seeds(args.seeds)]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    records: list[dict[str, Any]] = []
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[ok]} ok"),
        TimeRemainingColumn(),
    )
    with (
        (out / "runs.jsonl").open("a", encoding="utf-8") as log,
        Progress(*columns) as progress,
        ProcessPoolExecutor(max_workers=args.workers) as pool,
    ):
        task = progress.add_task(f"{args.tree} x {len(jobs)}", total=len(jobs), ok=0)
        futures = [pool.submit(one_run, args.tree, rig, seed, overrides) for rig, seed in jobs]
        for future in as_completed(futures):
            record = future.result()
            record["faults"] = bool(args.faults)
            records.append(record)
            log.write(json.dumps(record) + "\n")
            log.flush()
            progress.update(task, advance=1, ok=sum(r["ok"] for r in records))
    print(summarise(records))


if __name__ == "__main__":
    main()
