"""The real-hardware code path on the wall clock, against ``armtree serve-sim``.

Run: ``python benchmarks/bench_hil.py [--profile sim_dobot] [--rig dobot_v1.yaml] [--runs 1]``.

``armtree serve-sim PROFILE --stamp-frames --frame-log F`` runs as its own process
(the firmware emulator on a pty, the camera as MJPEG over HTTP, each frame's index
stamped in its top-left corner); this process runs ``load_ducky.yaml`` on the
real-hardware profile pointed at them (pyserial on the tty, OpenCV capture of the
stream, the wall clock, 20 Hz ticks) and measures:

* tick jitter: how late each tick starts against its schedule (p50, p99, max) and
  the overruns (ticks whose work outlasted the period), with each tick's own
  work time beside them;
* camera latency, in ``time.monotonic`` seconds (one clock for both processes on
  Linux): render start -> frame published (serve-sim), -> frame handed to a tick
  by ``camera.read()``, -> the tracker's detections ready;
* end-to-end: the run's status and the served world's score.

Peer in the same run: a bare 20 Hz loop (``Event.wait`` to each tick's time, no
work) in this process for as many ticks, right before the run: the jitter floor
the machine's scheduler gives. The load average is printed; the machine is shared.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

import armtree
from armtree.api.clock import WallClock
from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.plugins.sim.serve import read_stamp
from armtree.runtime.rig_builder import build_rig
from armtree.runtime.run_end import lateness_ms
from armtree.runtime.runner import Run


def bare_loop(ticks: int, hz: float = 20.0) -> list[float]:
    """Lateness (s) of each tick of a loop that only waits for its schedule."""
    wake = threading.Event()
    period, late = 1.0 / hz, []
    t0 = next_t = time.monotonic()
    for k in range(ticks):
        now = time.monotonic()
        late.append(now - next_t)
        next_t = t0 + (k + 1) * period
        wake.wait(max(0.0, next_t - time.monotonic()))
    return late


def pct(values: list[float], q: float) -> float:
    """The q-quantile of ``values`` (nearest rank)."""
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * (len(ordered) - 1) + 0.5))]


def one_run(profile: str, rig_name: str, workdir: Path) -> dict:
    """serve-sim + one load_ducky run on the real-hardware path; the figures as a dict."""
    frame_log = workdir / "frames.jsonl"
    exe = Path(sys.executable).parent / "armtree"
    server = subprocess.Popen(
        [str(exe), "serve-sim", profile, "--stamp-frames", "--frame-log", str(frame_log)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=workdir,
    )
    lines = dict(server.stdout.readline().strip().split(": ", 1) for _ in range(3))
    port, url = lines["arm port"], lines["camera"]
    try:
        tree = armtree.load_tree(
            "load_ducky.yaml", rig=rig_name, overrides=[f"arm.port={port}", f"camera.device={url}"]
        )
        manager = get_plugin_manager()
        rig = build_rig(tree.profile, manager, WallClock())
        reads: dict[int, float] = {}
        detected: dict[int, float] = {}
        read, detect = rig.camera.read, rig.tracker.detect

        def timed_read():
            frame = read()
            if frame is not None:
                reads.setdefault(read_stamp(frame.image), time.monotonic())
            return frame

        def timed_detect(frame):
            found = detect(frame)
            detected.setdefault(read_stamp(frame.image), time.monotonic())
            return found

        rig.camera.read, rig.tracker.detect = timed_read, timed_detect
        work: list[float] = []

        class TickWork:
            """Each tick's own time (``run.tick_wall``, the tick before the hook's)."""

            @armtree.hookimpl
            def armtree_tick(self, run: Run) -> None:
                work.append(getattr(run, "tick_wall", 0.0))

        manager.register(TickWork(), "bench-tick-work")
        floor = bare_loop(200)
        load_before = os.getloadavg()
        run = Run(
            tree,
            rig,
            record=workdir / "run",
            handle_signals=False,
            stop_key=False,
            close_rig=True,
            manager=manager,
        )
        try:
            result = run.execute()
        finally:
            manager.pm.unregister(name="bench-tick-work")
        load_after = os.getloadavg()
    finally:
        server.send_signal(signal.SIGINT)
        served, _ = server.communicate(timeout=30)
    score = next((x for x in served.splitlines() if x.startswith("score: ")), "score: ?")
    frames = {}
    for line in frame_log.read_text().splitlines():
        rec = json.loads(line)
        frames[rec["index"]] = (rec["render"], rec["sent"])
    sent = [frames[i][1] - frames[i][0] for i in frames]
    to_read = [reads[i] - frames[i][0] for i in reads if i in frames]
    to_detect = [detected[i] - frames[i][0] for i in detected if i in frames]
    return {
        "status": result.status,
        "score": score.removeprefix("score: "),
        "ticks": result.ticks,
        "overruns": result.overruns,
        "lateness_ms": lateness_ms(run.tick_lateness),
        "floor_ms": lateness_ms(floor),
        "tick_work_ms": lateness_ms(work[1:]),
        "render_to_sent_ms": [1000 * pct(sent, q) for q in (0.5, 0.99)],
        "render_to_read_ms": [1000 * pct(to_read, q) for q in (0.5, 0.99)] if to_read else [],
        "render_to_detection_ms": [1000 * pct(to_detect, q) for q in (0.5, 0.99)]
        if to_detect
        else [],
        "detections_matched": len(to_detect),
        "load": [round(x, 1) for x in (*load_before[:1], *load_after[:1])],
    }


def main() -> None:
    """Run the benchmark and print its table (and JSON with --json)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--profile", default="sim_dobot", help="sim profile serve-sim serves")
    parser.add_argument("--rig", default="dobot_v1.yaml", help="real-hardware profile of the run")
    parser.add_argument("--runs", type=int, default=1, help="runs, one after another")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON too")
    args = parser.parse_args()
    results = []
    for _ in range(args.runs):
        with tempfile.TemporaryDirectory() as tmp:
            results.append(one_run(args.profile, args.rig, Path(tmp)))
    for r in results:
        late, floor = r["lateness_ms"], r["floor_ms"]
        print(f"{args.rig} against serve-sim {args.profile}: {r['status']}; world: {r['score']}")
        print(
            f"  tick start after schedule (20 Hz, {late['ticks']:.0f} ticks): "
            f"p50 {late['p50']:.2f} ms, p99 {late['p99']:.2f} ms, max {late['max']:.1f} ms; "
            f"overruns {r['overruns']}"
        )
        work = r["tick_work_ms"]
        print(
            f"  a tick's own work: p50 {work['p50']:.2f} ms, p99 {work['p99']:.2f} ms, "
            f"max {work['max']:.1f} ms (period 50 ms)"
        )
        print(
            f"  bare 20 Hz loop, same process, just before: p50 {floor['p50']:.2f} ms, "
            f"p99 {floor['p99']:.2f} ms, max {floor['max']:.1f} ms "
            f"(run p99 / floor p99 = {late['p99'] / max(floor['p99'], 1e-3):.1f})"
        )
        for key, label in (
            ("render_to_sent_ms", "render -> published"),
            ("render_to_read_ms", "render -> read by a tick"),
            ("render_to_detection_ms", "render -> detections"),
        ):
            if r[key]:
                print(f"  camera {label}: p50 {r[key][0]:.1f} ms, p99 {r[key][1]:.1f} ms")
        print(f"  frames detected and matched: {r['detections_matched']}; load {r['load']}")
    if args.json:
        print(json.dumps(results, indent=2))
    if any(r["status"] != "SUCCESS" for r in results):
        sys.exit(1)


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
