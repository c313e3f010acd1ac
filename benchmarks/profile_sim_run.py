"""Where a simulated run's CPU goes, per rig: py-spy on forked runs, samples grouped by part.

Each seed runs as ``armtree sweep`` runs it: a process that has imported armtree
forks a child per run. py-spy (a sampling profiler; ``pip install py-spy``, a
developer's tool, not a dependency of armtree) is attached to the child before it
starts and samples every thread 250 times a second, counting only samples in which
the thread was on a CPU (and not in a wait, which py-spy may count as running). A sample is put in the first part of this list whose
modules appear anywhere on its stack: start-up (loading the tree, building the rig
and the renderer on the run's thread), rendering (the renderer, drawing the world,
the sim camera; the renderer's noise bank on its own thread), detection (the
trackers), planning, the emulator's side of the serial exchange (pty), the world's
step, the driver's side (its thread and its calls), logging, kinematics and the
shared maths, the skills, and the tick loop (runtime, py_trees, the rig's API).

Usage::

    python benchmarks/profile_sim_run.py --rigs sim_dobot sim_dh --seeds 9101-9102

It prints, per rig, the CPU milliseconds per run of each part and its share.
"""

from __future__ import annotations

import argparse
import collections
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

RIGS = ["sim_dobot", "sim_vicra", "sim_magician", "sim_dh"]
RATE = 250

#: Parts in the order a sample is matched: (name, path fragments of its frames).
PARTS = [
    ("start-up", ["build_rig", "load_tree", "make_plugin_manager", "Renderer.__init__"]),
    ("noise bank (own thread)", ["_noise_bank"]),
    ("render", ["sim/renderer.py", "sim/drawing.py", "sim/camera.py", "sim/markers.py"]),
    ("detection", ["plugins/trackers/"]),
    ("planning", ["plugins/planners/"]),
    ("emulator (pty)", ["emulator.py", "barrier.py"]),
    ("world step", ["plugins/sim/"]),
    ("driver (pty)", ["driver.py", "plugins/arms/common/", "serial/", "serial "]),
    ("logging", ["runlog.py", "feedback_log", "blackboard_log", "run_hooks", "recording.py"]),
    ("kinematics and maths", ["kinematics.py", "core/maths/"]),
    ("skills", ["plugins/skills/"]),
    ("tick loop", ["core/runtime/", "py_trees/", "core/api/"]),
]


#: Leaf frames of a thread blocked in a wait, which py-spy may still count as running.
WAITS = ("Condition.wait", "_wait_for_tstate_lock", "Event.wait", "Serial.read ", "select ")


def profile(rig: str, seeds: list[int], out: Path) -> list[Path]:
    """Run each seed in a forked child with py-spy attached; the raw sample files."""
    from armtree.cli.sweep.task import RunTask, run_task
    from armtree.hooks.plugin_manager import get_plugin_manager

    get_plugin_manager().registry  # noqa: B018 - imports every plugin, as the sweep's forker does
    files = []
    for seed in seeds:
        go_read, go_write = os.pipe()
        pid = os.fork()
        if pid == 0:
            os.close(go_write)
            os.read(go_read, 1)  # wait until py-spy is attached
            with tempfile.TemporaryDirectory() as runs:
                run_task(RunTask(tree="load_ducky.yaml", seed=seed, run_dir=runs, rig=rig))
            os._exit(0)
        os.close(go_read)
        path = out / f"{rig}-{seed}.txt"
        spy = subprocess.Popen(
            ["py-spy", "record", "--pid", str(pid), "--threads", "-r", str(RATE)]
            + ["-f", "raw", "-o", str(path)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        time.sleep(1.0)  # py-spy attaches well within this
        os.write(go_write, b"x")
        os.close(go_write)
        os.waitpid(pid, 0)
        spy.wait()
        files.append(path)
    return files


def parts_of(files: list[Path]) -> dict[str, float]:
    """CPU milliseconds per run of each part, from py-spy's raw (collapsed) samples."""
    spent: collections.Counter[str] = collections.Counter()
    for path in files:
        for line in path.read_text().splitlines():
            stack, _, count = line.rpartition(" ")
            if stack.rsplit(";", 1)[-1].startswith(WAITS):
                continue
            part = next((n for n, frags in PARTS if any(f in stack for f in frags)), "other")
            spent[part] += int(count)
    return {k: v * 1000 / RATE / len(files) for k, v in spent.items()}


def _seed_list(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rigs", nargs="+", default=RIGS)
    parser.add_argument("--seeds", default="9101-9102")
    args = parser.parse_args()
    if subprocess.run(["py-spy", "--version"], capture_output=True).returncode != 0:
        sys.exit("py-spy is needed: pip install py-spy")
    print(f"load average {os.getloadavg()[0]:.2f} at the start")
    with tempfile.TemporaryDirectory() as tmp:
        table = {
            rig: parts_of(profile(rig, _seed_list(args.seeds), Path(tmp))) for rig in args.rigs
        }
    names = [name for name, _ in PARTS] + ["other"]
    print("| part (CPU ms per run, share) | " + " | ".join(args.rigs) + " |")
    print("| --- " * (len(args.rigs) + 1) + "|")
    for name in names:
        cells = []
        for rig in args.rigs:
            ms, total = table[rig].get(name, 0.0), sum(table[rig].values())
            cells.append(f"{ms:.0f} ({ms / total:.0%})")
        print(f"| {name} | " + " | ".join(cells) + " |")
    print("| all | " + " | ".join(f"{sum(table[r].values()):.0f}" for r in args.rigs) + " |")
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
