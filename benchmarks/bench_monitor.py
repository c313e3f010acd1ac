"""Monitor cost, latency and recording size.

1. Cost: the same simulated run (same tree, same seed) at 20 Hz in real time, with
   ``--monitor`` and a page showing it (headless Chromium drawing the tree, the camera
   stream and the overhead view), and without a monitor (paced the same way),
   alternating, several rounds. Reported: the run thread's mean tick work (wall ms,
   everything between two ticks' sleeps: rig step, tree tick, logging, tick hooks)
   and the run process's CPU time per tick (all its threads: the page's server, JPEG
   encoding, scene sampling), each with and without, and the difference as a share
   of the 50 ms tick. Goal: < 5 %. Chromium's own CPU (another process) is not counted.
2. Latency: for every status change the page drew, the wall time from the end of the
   tick that made it to the page's next animation frame (loopback): over the cost runs,
   and over a tree whose statuses change every tick. Goal: < 100 ms.
3. Size: run.mcap of ``load_ducky.yaml`` recorded with ``--record`` (virtual clock,
   as fast as it goes), per minute of run time, by channel.

Usage: python benchmarks/bench_monitor.py [--tree pick_and_place.yaml] [--rounds 3]
       [--no-browser]  (without Chromium: a websocket client that takes every frame)
"""

from __future__ import annotations

import argparse
import asyncio
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import armtree
from armtree.cli.run_command import plugin_manager_for
from armtree.loader.tree_loader import load_tree
from armtree.plugins.monitor.chromium import CHROMIUM
from armtree.runtime.runner import Run


class TickTimes:
    """Collects each tick's work (``run.tick_wall``)."""

    def __init__(self) -> None:
        self.walls: list[float] = []

    @armtree.hookimpl
    def armtree_tick(self, run):
        self.walls.append(run.tick_wall)


def cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


#: The browser side, in a process of its own so its CPU is not charged to the run's.
BROWSER_SCRIPT = """
import json, sys, time
from playwright.sync_api import sync_playwright
from armtree.plugins.monitor.chromium import launch
with sync_playwright() as p:
    browser = launch(p)
    page = browser.new_page(viewport={"width": 1600, "height": 1000})
    page.goto(sys.argv[1])
    print("ready", flush=True)
    state = [[], [], 0, ""]
    while not (state[3] or "").startswith("ended"):
        time.sleep(0.2)
        try:
            state = page.evaluate(
                "() => [window.armtree.log.latencies.slice(), window.armtree.log.received.slice(), "
                "Number(document.querySelector('#camera').dataset.frames || 0), "
                "document.body.dataset.state]"
            )
        except Exception:
            break
    print(json.dumps({"latencies": state[0], "received": state[1], "frames": state[2]}), flush=True)
    browser.close()
"""


class BrowserPage:
    """Headless Chromium showing the monitor page (another process); its latencies."""

    def __init__(self) -> None:
        self.latencies: list[float] = []
        self.received: list[float] = []
        self.frames = 0
        self._proc: subprocess.Popen | None = None

    def open(self, url: str) -> None:
        self._proc = subprocess.Popen(
            [sys.executable, "-c", BROWSER_SCRIPT, url], stdout=subprocess.PIPE, text=True
        )
        assert self._proc.stdout is not None
        self._proc.stdout.readline()  # "ready"

    def close(self) -> None:
        if self._proc is None:
            return
        out, _ = self._proc.communicate(timeout=60)
        found = json.loads(out.strip().splitlines()[-1])
        self.latencies, self.frames = found["latencies"], found["frames"]
        self.received = found["received"]


class SocketPage:
    """A websocket client in place of a browser: takes every frame, notes latencies."""

    def __init__(self) -> None:
        self.latencies: list[float] = []
        self.received = self.latencies
        self.frames = 0
        self._thread: threading.Thread | None = None

    def open(self, url: str) -> None:
        ready = threading.Event()

        async def run() -> None:
            import aiohttp

            async with (
                aiohttp.ClientSession() as session,
                session.ws_connect(url.rstrip("/") + "/ws") as ws,
            ):
                ready.set()
                letters = None
                async for msg in ws:
                    if msg.type == aiohttp.WSMsgType.BINARY:
                        self.frames += 1
                        await ws.send_str('{"type": "image_ack"}')
                        continue
                    if msg.type != aiohttp.WSMsgType.TEXT:
                        break
                    data = json.loads(msg.data)
                    if data.get("type") == "tick" and data["letters"] != letters:
                        letters = data["letters"]
                        self.latencies.append(time.time() - data["wall"])

        self._thread = threading.Thread(target=lambda: asyncio.run(run()), daemon=True)
        self._thread.start()
        ready.wait(30)

    def close(self) -> None:
        if self._thread is not None:
            self._thread.join(30)


def execute_paced(run: Run, watch: Callable[[], None] | None) -> tuple[Any, float]:
    """Execute ``run`` with ``watch`` on a thread (it resumes the paused run once its
    client is up), or paced to real time without one; the result and the process CPU
    seconds it took."""
    if watch is not None:
        threading.Thread(target=watch, daemon=True).start()
    else:
        run.control.speed = 1.0
    cpu0 = cpu_seconds()
    result = run.execute()
    return result, cpu_seconds() - cpu0


def one_run(tree_name: str, seed: int, monitored: bool, browser: bool) -> dict:
    manager = plugin_manager_for(None, None)
    times = TickTimes()
    manager.register(times, "bench_tick_times")
    tree = load_tree(tree_name, manager=manager)
    settings = {"monitor": 0} if monitored else {}
    run = Run(tree, seed=seed, manager=manager, record=False, quiet=True, settings=settings)
    page = None
    if monitored:
        # The page opens once the server is up; the run waits for it (paused) so every
        # tick is watched.
        run.control.pause()

        def watch() -> None:
            nonlocal page
            while not run.plugin_state.get("monitor") or not run.plugin_state["monitor"].feeds:
                time.sleep(0.01)
            url = run.plugin_state["monitor"].feeds[0].server.url
            page = BrowserPage() if browser else SocketPage()
            page.open(url)
            time.sleep(1.0)
            run.control.resume()

    result, cpu = execute_paced(run, watch if monitored else None)
    manager.pm.unregister(times)
    if page is not None:
        page.close()
    walls = times.walls
    return {
        "ticks": result.ticks,
        "status": result.status,
        "tick_ms": 1000 * statistics.fmean(walls),
        "cpu_ms_per_tick": 1000 * cpu / max(1, result.ticks),
        "overruns": result.overruns,
        "latencies": list(page.latencies) if page is not None else [],
        "received": list(page.received) if page is not None else [],
        "frames": page.frames if page is not None else 0,
        "tick_hz": run.tick_hz,
    }


def cost(tree: str, rounds: int, browser: bool) -> None:
    results: dict[bool, list[dict]] = {False: [], True: []}
    for r in range(rounds):
        for monitored in (False, True) if r % 2 == 0 else (True, False):
            res = one_run(tree, 0, monitored, browser)
            results[monitored].append(res)
            what = "monitor + page" if monitored else "no monitor   "
            print(
                f"  round {r + 1} {what}: {res['ticks']} ticks {res['status']}, tick work "
                f"{res['tick_ms']:.2f} ms, process CPU {res['cpu_ms_per_tick']:.2f} ms/tick, "
                f"overruns {res['overruns']}, camera frames on the page {res['frames']}",
                flush=True,
            )
    print_cost(tree, rounds, results)
    report_latency(f"{tree}, with the camera stream", results[True])


def print_cost(tree: str, rounds: int, results: dict[bool, list[dict]]) -> None:
    """The medians of runs without (``results[False]``) and with (``results[True]``):
    tick work and process CPU per tick, and the difference as a share of the tick."""
    period_ms = 1000 / results[True][0]["tick_hz"]
    base_work = statistics.median(r["tick_ms"] for r in results[False])
    mon_work = statistics.median(r["tick_ms"] for r in results[True])
    base_cpu = statistics.median(r["cpu_ms_per_tick"] for r in results[False])
    mon_cpu = statistics.median(r["cpu_ms_per_tick"] for r in results[True])
    print(f"tree {tree}, {rounds} rounds each, medians; tick period {period_ms:.0f} ms")
    print(
        f"tick work on the run thread: {base_work:.2f} ms without, {mon_work:.2f} ms with: "
        f"{mon_work - base_work:+.2f} ms = {100 * (mon_work - base_work) / period_ms:.1f} % of "
        f"the tick ({100 * (mon_work - base_work) / base_work:.1f} % of the work)"
    )
    print(
        f"process CPU per tick: {base_cpu:.2f} ms without, {mon_cpu:.2f} ms with: "
        f"{mon_cpu - base_cpu:+.2f} ms = {100 * (mon_cpu - base_cpu) / period_ms:.1f} % of the tick"
    )


#: A tree whose statuses change every tick, for the latency figure (15 s at 20 Hz).
FLICKER = """\
tree: flicker
tick_hz: 20
root:
  repeat:
    name: Forever
    num_success: 100
    child:
      sequence:
        name: Cycle
        children:
          - tick_counter: {name: A, duration: 1}
          - tick_counter: {name: B, duration: 1}
"""


def latency(browser: bool) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "flicker.yaml"
        path.write_text(FLICKER)
        report_latency("a tree changing every tick", [one_run(str(path), 0, True, browser)])


def report_latency(what: str, results: list[dict]) -> None:
    for key, label in (("received", "received by the page"), ("latencies", "drawn")):
        latencies = sorted(x for r in results for x in r[key])
        if not latencies:
            print(f"status change to page ({what}): none measured")
            return
        p95 = latencies[min(len(latencies) - 1, int(0.95 * len(latencies)))]
        print(
            f"status change {label} ({what}; {len(latencies)} changes): median "
            f"{1000 * statistics.median(latencies):.1f} ms, 95th percentile {1000 * p95:.1f} ms, "
            f"max {1000 * latencies[-1]:.1f} ms"
        )


def size(tree: str) -> None:
    from mcap.reader import make_reader

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "rec"
        manager = plugin_manager_for(None, None)
        result = armtree.run(load_tree(tree, manager=manager), manager=manager, record=out)
        path = out / "run.mcap"
        total = path.stat().st_size
        per_topic: dict[str, list[int]] = {}
        with path.open("rb") as fh:
            for _, channel, message in make_reader(fh).iter_messages():
                entry = per_topic.setdefault(channel.topic, [0, 0])
                entry[0] += 1
                entry[1] += len(message.data)
        minutes = result.seconds / 60
        print(
            f"run.mcap of {tree}: {total / 1e6:.2f} MB for {result.seconds:.1f} s of run "
            f"= {total / 1e6 / minutes:.1f} MB per minute (zstd chunks); uncompressed by channel:"
        )
        for topic, (count, raw) in sorted(per_topic.items(), key=lambda kv: -kv[1][1]):
            print(f"  {topic:22s} {count:6d} messages {raw / 1e6 / minutes:8.2f} MB/min")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tree", default="pick_and_place.yaml", help="tree for the cost runs")
    parser.add_argument("--rounds", type=int, default=3, help="runs with and without, each")
    parser.add_argument(
        "--no-browser", action="store_true", help="a websocket client, not Chromium"
    )
    parser.add_argument("--size-tree", default="load_ducky.yaml", help="tree for the size figure")
    parser.add_argument("--skip-cost", action="store_true")
    args = parser.parse_args()
    browser = not args.no_browser and Path(CHROMIUM).exists()
    if not args.skip_cost:
        cost(args.tree, args.rounds, browser)
    latency(browser)
    size(args.size_tree)


if __name__ == "__main__":
    main()
