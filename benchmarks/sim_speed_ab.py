"""Speed of simulated runs on two source trees of armtree, and whether they run alike.

Runs ``load_ducky.yaml`` (or ``--tree``) for each seed and rig, once on each
source tree (``--base``, e.g. an export of main, and ``--new``, default this
checkout), alternating which goes first from rig to rig. Every run is a forked
child of a process that has already imported armtree, as in ``armtree sweep``;
it reports the run's simulated seconds, its ``wall_seconds`` and its CPU
seconds (``time.process_time``, the arm driver's thread included) and its
thread switches per tick (voluntary context switches of all its threads: each
is a thread that went to sleep waiting for another, a count the machine's load
hardly moves). Per rig it prints the medians and simulated time over wall and
over CPU time (x faster than real time), and whether each seed's ``run.jsonl`` (clock and path fields
left out), ``score.json`` (the same) and every rendered frame are the same on both trees.

Usage::

    git archive main | tar -x -C /tmp/base
    python benchmarks/sim_speed_ab.py --base /tmp/base --rigs sim_dobot sim_dh --seeds 1-4

With ``--interleave`` each seed runs on both trees back to back (one child process
each), and the medians of the per-seed ratios are printed too: on a machine whose
load comes and goes they say more than the medians of each tree's runs.
``--set KEY=VALUE`` (repeatable) gives every run a profile override, e.g. the
fault sweeps' dropped frames and missed steps.

A source tree is swapped in by pointing this venv's editable install of armtree
at it, so it must be installed with ``pip install -e`` (the project's own setup).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: Run-log fields that differ between any two runs (clocks) or source trees (paths).
VOLATILE = {"started", "wall_seconds", "tick_lateness_ms", "source"}


def _seeds(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += range(int(lo), int(hi or lo) + 1)
    return out


def _use_source(src: Path) -> None:
    """Point the editable install's import finder at ``src`` (before armtree is imported)."""
    # The .pth file of ``pip install -e`` imported the finder at start-up.
    finder = next(m for n, m in sys.modules.items() if n.startswith("__editable___armtree_"))
    finder.MAPPING.update(
        {
            "armtree": str(src / "core"),
            "armtree.hardware": str(src / "hardware"),
            "armtree.plugins": str(src / "plugins"),
            "armtree.trees": str(src / "trees"),
        }
    )


def _strip(value, src: str):
    if isinstance(value, dict):
        return {k: _strip(v, src) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        return [_strip(v, src) for v in value]
    return value.replace(src, "SRC") if isinstance(value, str) else value


def child(args: argparse.Namespace) -> None:
    """One source tree: run every seed of one rig in forked children; print one JSON line each."""
    src = Path(args.source).resolve()
    _use_source(src)
    from armtree.hooks.plugin_manager import make_plugin_manager
    from armtree.loader.tree_loader import load_tree
    from armtree.plugins.sim import renderer
    from armtree.runtime.runner import run

    frames: list[str] = []
    render = renderer.Renderer.render

    def hashed(self, *a, **k):
        image = render(self, *a, **k)
        frames.append(hashlib.sha1(image.tobytes()).hexdigest()[:16])
        return image

    renderer.Renderer.render = hashed
    tree_path = src / "trees" / args.tree if not Path(args.tree).is_absolute() else args.tree
    for seed in _seeds(args.seeds):
        read, write = os.pipe()
        if os.fork() == 0:
            os.close(read)
            with tempfile.TemporaryDirectory() as runs:
                manager = make_plugin_manager((), ())
                tree = load_tree(str(tree_path), rig=args.rig, overrides=args.set, manager=manager)
                cpu0 = time.process_time()
                switches0 = resource.getrusage(resource.RUSAGE_SELF).ru_nvcsw
                result = run(
                    tree,
                    seed=seed,
                    record=True,
                    runs_dir=runs,
                    quiet=True,
                    manager=manager,
                    stop_key=False,
                )
                cpu = time.process_time() - cpu0
                switches = resource.getrusage(resource.RUSAGE_SELF).ru_nvcsw - switches0
                log = next(Path(runs).rglob("run.jsonl"))
                score = log.with_name("score.json")
                same = {
                    "log": [_strip(json.loads(line), str(src)) for line in log.open()],
                    "score": _strip(json.loads(score.read_text()), str(src))
                    if score.exists()
                    else None,
                    "frames": frames,
                }
            digest = hashlib.sha1(json.dumps(same, sort_keys=True).encode()).hexdigest()
            line = {
                "seed": seed,
                "status": result.status,
                "sim": result.seconds,
                "wall": result.wall_seconds,
                "cpu": cpu,
                "switches_per_tick": switches / max(1, result.ticks),
                "digest": digest,
            }
            os.write(write, json.dumps(line).encode())
            os._exit(0)
        os.close(write)
        data = b""
        while chunk := os.read(read, 65536):
            data += chunk
        os.wait()
        print(data.decode(), flush=True)


def _child_runs(src: str, rig: str, seeds: str, tree: str, overrides: list[str] = ()) -> list[dict]:
    """Run ``seeds`` of ``rig`` on source tree ``src`` in a child process; one dict per seed."""
    cmd = [
        sys.executable,
        __file__,
        "--source",
        src,
        "--rig",
        rig,
        "--seeds",
        seeds,
        "--tree",
        tree,
    ]
    for override in overrides:
        cmd += ["--set", override]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return [json.loads(line) for line in out.splitlines() if line.startswith("{")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", help="source tree to compare against (required)")
    parser.add_argument("--new", default=str(Path(__file__).resolve().parents[1]))
    parser.add_argument(
        "--rigs",
        nargs="+",
        default=["sim_dobot", "sim_vicra", "sim_magician", "sim_dh"],
    )
    parser.add_argument("--seeds", default="1-4")
    parser.add_argument("--tree", default="load_ducky.yaml")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="profile override for every run (repeatable), e.g. faults",
    )
    parser.add_argument(
        "--interleave",
        action="store_true",
        help="run each seed on both trees back to back (for a machine whose load varies)",
    )
    parser.add_argument("--source", help=argparse.SUPPRESS)
    parser.add_argument("--rig", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.source:
        child(args)
        return
    if not args.base:
        parser.error("--base SOURCE_TREE is required")
    print(f"load average {os.getloadavg()[0]:.1f}")
    trees = [("base", args.base), ("new", args.new)]
    for i, rig in enumerate(args.rigs):
        runs: dict[str, list[dict]] = {"base": [], "new": []}
        if args.interleave:
            # Each seed on both trees back to back: a load that comes and goes hits both.
            for k, seed in enumerate(_seeds(args.seeds)):
                for name, src in trees if (i + k) % 2 == 0 else trees[::-1]:
                    runs[name] += _child_runs(src, rig, str(seed), args.tree, args.set)
        else:
            for name, src in trees if i % 2 == 0 else trees[::-1]:
                runs[name] = _child_runs(src, rig, args.seeds, args.tree, args.set)
        for name in ("base", "new"):
            r = runs[name]
            sim = statistics.median(x["sim"] for x in r)
            wall = statistics.median(x["wall"] for x in r)
            cpu = statistics.median(x["cpu"] for x in r)
            switches = statistics.median(x["switches_per_tick"] for x in r)
            print(
                f"{rig} {name}: median {sim:.1f} s simulated, {wall:.2f} s wall "
                f"({sim / wall:.1f}x), {cpu:.2f} s CPU ({sim / cpu:.1f}x), "
                f"{switches:.2f} thread switches per tick"
            )
        same = sum(
            a["digest"] == b["digest"] for a, b in zip(runs["base"], runs["new"], strict=True)
        )
        print(f"{rig}: {same} of {len(runs['base'])} seeds run alike (log, score, frames)")
        if args.interleave:
            pairs = list(zip(runs["base"], runs["new"], strict=True))
            wall = statistics.median(a["wall"] / b["wall"] for a, b in pairs)
            cpu = statistics.median(a["cpu"] / b["cpu"] for a, b in pairs)
            print(
                f"{rig}: new runs {wall:.2f}x as fast by wall, {cpu:.2f}x by CPU (median of seeds)"
            )
    print(f"load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
