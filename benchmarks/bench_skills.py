"""load_ducky on the simulation: simulated seconds per wall second, and where the wall time goes.

Measured in this run, best of ``--rounds``:

* ``load_ducky``: the shipped tree on sim_dobot (emulated Dobot behind a pty,
  rendered eye-in-hand frames, ArUco, PRM planner), with the camera mount the
  skills' integration test uses; goal: >= 10x faster than real time;
* baseline ``idle``: a ``wait`` tree on the same profile for the same simulated
  time, so the tick loop, the firmware emulator and the world step with no
  skill, no rendering and no detection (the floor of any simulated run);
* the wall time inside the camera (rendering) and the tracker (detection)
  during the load_ducky round.

Usage: python benchmarks/bench_skills.py [--rounds N]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from armtree.loader.tree_loader import load_tree
from armtree.plugins.sim.rig_world import sim_world
from armtree.runtime.runner import Run

CAMERA = "camera.position=[0,40,60]"


class Stopwatch:
    """Accumulates the wall time of calls to one method of one object."""

    def __init__(self, owner: object, name: str) -> None:
        self.total = 0.0
        self.calls = 0
        inner = getattr(owner, name)

        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                self.total += time.perf_counter() - t0
                self.calls += 1

        setattr(owner, name, timed)


def run_once(tree_name: str, overrides: list[str]) -> dict:
    """One run from loading to the end; its status, simulated and wall seconds, ticks, score."""
    tree = load_tree(tree_name, overrides=overrides)
    run = Run(tree, None, seed=0, record=False, max_ticks=20000, quiet=True)
    t0 = time.perf_counter()
    result = run.execute()
    wall = time.perf_counter() - t0
    out = {"status": result.status, "sim": result.seconds, "wall": wall, "ticks": result.ticks}
    if run.rig is not None and run.rig.camera is not None:
        out["score_ok"] = float(sim_world(run).score()["ducky_on_duckybot"])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()

    import armtree.plugins.sim.camera as sim_camera
    import armtree.plugins.trackers.aruco as aruco

    render = Stopwatch(sim_camera.SimCamera, "read")
    detect = Stopwatch(aruco.ArucoTracker, "detect")

    best: dict[str, float] | None = None
    for _ in range(args.rounds):
        render.total = detect.total = 0.0
        got = run_once("load_ducky.yaml", [CAMERA])
        got["render"], got["detect"] = render.total, detect.total
        if best is None or got["wall"] < best["wall"]:
            best = got
    assert best is not None
    with tempfile.TemporaryDirectory() as tmp:
        idle_tree = Path(tmp) / "idle.yaml"
        idle_tree.write_text(
            f"tree: idle\nrig: sim_dobot\ntick_hz: 20\nroot: {{wait: {{seconds: {best['sim']:.2f}}}}}\n"
        )
        idle = min(
            (run_once(str(idle_tree), [CAMERA]) for _ in range(args.rounds)),
            key=lambda r: r["wall"],
        )
    ratio = best["sim"] / best["wall"]
    idle_ratio = idle["sim"] / idle["wall"]
    print(f"load_ducky: {best['status']}, ducky on Duckybot: {bool(best.get('score_ok'))}")
    print(
        f"  {best['sim']:.1f} s simulated in {best['wall']:.2f} s wall "
        f"= {ratio:.1f}x real time (goal >= 10x), {best['ticks']} ticks"
    )
    print(
        f"  camera read/render {best['render']:.2f} s ({best['render'] / best['wall']:.0%}), "
        f"ArUco detect {best['detect']:.2f} s ({best['detect'] / best['wall']:.0%}), "
        f"the rest (ticks, skills, planner, emulator, world) "
        f"{best['wall'] - best['render'] - best['detect']:.2f} s"
    )
    print(
        f"baseline idle (wait tree, same profile and simulated time): "
        f"{idle['wall']:.2f} s wall = {idle_ratio:.1f}x real time"
    )
    print(f"load_ducky wall / idle wall: {best['wall'] / idle['wall']:.2f}")


if __name__ == "__main__":
    main()
