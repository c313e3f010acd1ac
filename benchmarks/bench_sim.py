"""Simulation speed: rendered frames per second, and simulated against wall-clock time.

Rendering: 640x480 frames with five ArUco markers in view on one core
(cv2.setNumThreads(1)), for a still eye-to-hand camera, and for the Dobot's
eye-in-hand C270 (with its lens distortion) still and moving. Goal: >= 200
frames/s. Baselines measured in the same run, alternating rounds, best CPU
time of each: one full-frame cv2.remap of a 640x480 BGR image (a fixed
reference operation) and OpenCV's ArucoDetector.detectMarkers on the rendered
frames (what consuming a frame costs).

Run time: a scripted pick-and-place through a stand-in emulator on the
virtual clock (20 Hz ticks, every camera frame read), simulated seconds per
wall second; with --load-ducky also the full load_ducky tree on sim_dobot
(arm emulator, driver, skills, trackers), goal >= 10x real time.

Usage: python benchmarks/bench_sim.py [--frames N] [--rounds R] [--load-ducky [PROFILE ...]]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from sim_fakes import FakeEmulator  # noqa: E402

from armtree.api.clock import VirtualClock  # noqa: E402
from armtree.api.rig import RigContext  # noqa: E402
from armtree.plugins.sim.camera import sim_camera  # noqa: E402
from armtree.plugins.sim.world import world_for  # noqa: E402

PROFILE = {
    "tracker": {"type": "aruco", "dictionary": "4x4_50"},
    "tags": {
        "ducky": {"id": 0, "size_mm": 25},
        "duckybot": {"id": 1, "size_mm": 25},
        "trash": {"ids": [2, 3, 4, 5], "size_mm": 25},
    },
    "world": {
        "table": {"x": [-300, 500], "y": [-400, 400]},
        "objects": {
            "ducky": {"kind": "ducky", "at": [200, -60], "yaw": 20},
            "trash_a": {"kind": "trash", "at": [158, 40], "yaw": -15},
            "trash_b": {"kind": "trash", "at": [240, 45], "yaw": 35},
            "trash_c": {"kind": "trash", "at": [155, -50], "yaw": 5},
            "trash_d": {"kind": "trash", "at": [243, -25], "yaw": -40},
            "bin": {"kind": "bin", "at": [0, 250]},
        },
    },
}
C270 = {
    "mount": "eye_in_hand",
    "intrinsics": {"fx": 810.06, "fy": 810.76, "cx": 325.40, "cy": 249.02},
    "distortion": [0.01584, 0.37926, -0.00056, 0.00331, 0],
}
STAND = {
    "mount": "eye_to_hand",
    "intrinsics": {"fx": 570.0, "fy": 570.0, "cx": 320.0, "cy": 240.0},
    "position": [200, 0, 450],
    "look_at": [200, 0, 0],
}


def make(camera_config: dict, tool=(178, -15, 240)):
    """A world with five markers, a stand-in arm and a sim camera."""
    context = RigContext(profile=PROFILE, clock=VirtualClock(), seed=0)
    world = world_for(context)
    emulator = FakeEmulator()
    emulator.put(tool)
    world.attach_arm(emulator)
    camera = sim_camera(dict(camera_config, width=640, height=480, fps=1000.0), context)
    return context, world, emulator, camera


def render_round(case, n: int, moving: bool) -> tuple[float, list[np.ndarray]]:
    """CPU seconds per frame over ``n`` frames, and a few frames for the detector baseline.

    ``moving`` circles the arm's tool 5 mm around where it started, so every
    frame is drawn anew (and an eye-in-hand camera moves with it).
    """
    context, world, emulator, camera = case
    x0, y0, z0 = emulator.model.position(emulator.q)
    frames = []
    start = time.process_time()
    for k in range(n):
        if moving:
            emulator.put([x0 + 5 * np.sin(k * 0.2), y0 + 5 * np.cos(k * 0.2), z0])
            world.step(context.clock.now())
        context.clock.advance(0.001)
        frame = camera.read()
        if k < 10:
            frames.append(frame.image)
    return (time.process_time() - start) / n, frames


def remap_round(n: int) -> float:
    img = np.random.default_rng(0).integers(0, 255, (480, 640, 3), dtype=np.uint8)
    mx, my = np.meshgrid(np.arange(640, dtype=np.float32) + 0.3, np.arange(480, dtype=np.float32))
    start = time.process_time()
    for _ in range(n):
        cv2.remap(img, mx, my, cv2.INTER_LINEAR)
    return (time.process_time() - start) / n


def detect_round(frames: list[np.ndarray], n: int) -> tuple[float, int]:
    detector = cv2.aruco.ArucoDetector(
        cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50), cv2.aruco.DetectorParameters()
    )
    found = 0
    start = time.process_time()
    for k in range(n):
        _, ids, _ = detector.detectMarkers(frames[k % len(frames)])
        found = 0 if ids is None else len(ids)
    return (time.process_time() - start) / n, found


def bench_render(n: int, rounds: int) -> None:
    cv2.setNumThreads(1)
    cases = {
        "eye-to-hand, still": (make(STAND, tool=(100, -250, 240)), False),
        "eye-to-hand, arm moving": (make(STAND, tool=(100, -250, 240)), True),
        "eye-in-hand C270, still": (make(C270), False),
        "eye-in-hand C270, moving": (make(C270), True),
    }
    best = {name: np.inf for name in cases}
    best_remap, best_detect, markers = np.inf, np.inf, {}
    frames = {}
    for _ in range(rounds):
        best_remap = min(best_remap, remap_round(n))
        for name, (case, moving) in cases.items():
            t, frames[name] = render_round(case, n, moving)
            best[name] = min(best[name], t)
        for name in cases:
            t, markers[name] = detect_round(frames[name], max(10, n // 4))
            best_detect = min(best_detect, t)
    print(f"rendering 640x480, one core, best of {rounds} rounds of {n} frames (CPU time)")
    print(f"  baseline: full-frame cv2.remap        {best_remap * 1e3:6.2f} ms")
    print(f"  baseline: ArUco detectMarkers         {best_detect * 1e3:6.2f} ms")
    for name, t in best.items():
        print(
            f"  {name:28s} {t * 1e3:6.2f} ms  {1 / t:6.0f} frames/s  "
            f"= {t / best_remap:4.1f} remaps, {t / best_detect:4.2f} x detection; "
            f"markers detected {markers[name]}/5  (goal >= 200 frames/s)"
        )


def bench_pick_and_place() -> None:
    cv2.setNumThreads(1)
    context, world, emulator, camera = make(C270, tool=(200, -60, 200))
    camera.fps = 30.0
    clock = context.clock
    ducky = world.bodies["ducky"]
    above = np.array([200.0, -60.0, ducky.top + 40])
    top = np.array([200.0, -60.0, ducky.top])
    over_bin = np.array([0.0, 250.0, 120.0])
    script = [  # (target, suction while moving there and after)
        (above, False),
        (top, False),
        (top, True),
        (over_bin, True),
        (over_bin, False),
        (np.array([178.0, -15.0, 240.0]), False),
    ]
    wall0, cpu0 = time.perf_counter(), time.process_time()
    reads = 0
    for target, suction in script:
        emulator.target = emulator.model.ik(target)
        emulator.suction = suction
        for _ in range(50):  # 2.5 s at 20 Hz
            clock.advance(0.05)
            emulator.step(clock.now())
            world.step(clock.now())
            reads += camera.read() is not None
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    sim = clock.now()
    print("scripted pick-and-place (stand-in emulator, 20 Hz ticks, camera read every tick)")
    print(
        f"  {sim:.1f} s simulated in {wall:.2f} s wall ({cpu:.2f} s CPU): "
        f"{sim / wall:.1f}x real time ({sim / cpu:.1f}x per CPU second); {reads} frames "
        f"rendered; in the bin: {world.score()['in_bin']}"
    )


def bench_load_ducky(rig: str) -> None:
    from armtree.loader.tree_loader import load_tree
    from armtree.runtime.runner import run

    tree = load_tree("load_ducky.yaml", rig=rig)
    wall0 = time.perf_counter()
    result = run(tree, record=False, timeout=300, quiet=True)
    wall = time.perf_counter() - wall0
    print(f"load_ducky on {rig} (full stack: emulator, driver, skills, tracker; virtual clock)")
    print(
        f"  {result.status}: {result.seconds:.1f} s simulated in {wall:.2f} s wall: "
        f"{result.seconds / wall:.1f}x real time (goal >= 10x)  {result.message[:90]}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=200, help="frames per round")
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds")
    parser.add_argument(
        "--load-ducky",
        nargs="*",
        metavar="PROFILE",
        help="also time the load_ducky tree on these profiles (default: sim_vicra sim_dobot)",
    )
    args = parser.parse_args()
    bench_render(args.frames, args.rounds)
    bench_pick_and_place()
    if args.load_ducky is not None:
        for rig in args.load_ducky or ["sim_vicra", "sim_dobot"]:
            bench_load_ducky(rig)


if __name__ == "__main__":
    main()
