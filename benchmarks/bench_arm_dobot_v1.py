"""Link latencies of the Dobot V1 drivers (original and open-dobot) against their emulators.

Run: ``python benchmarks/bench_arm_dobot_v1.py [--moves 40]``. Each arm runs as
with ``--realtime``: the emulator serves its pseudo-terminal on the wall clock
and the real pyserial driver talks to it.

* command latency: from ``move_joints()`` returning to the command's first byte
  read by the firmware. The original firmware's protocol makes the host wait for
  the next status frame (one command per status frame, 50 ms period), so the
  driver's own share is reported too: from a status frame being parsed to the
  queued command written;
* status-to-handle latency: from the emulator writing a status frame (original)
  or a GET_COUNTERS reply (open-dobot) to the driver having parsed it and updated
  the motion handles (what a behaviour reads on its next tick).

Goal (issue 3): status-to-handle under one tick at 50 Hz (20 ms). Baseline in
the same run: the pseudo-terminal's own round trip.
"""

from __future__ import annotations

import argparse
import os
import statistics
import threading
import time
import tty

import numpy as np
from rich.console import Console
from rich.table import Table

from armtree.clock import WallClock
from armtree.emulation import SHARED_KEY
from armtree.plugins.arms.dobot_v1.plugin import dobot_v1_factory
from armtree.rig import RigContext


def pty_round_trip(samples: int = 300) -> list[float]:
    """Wall seconds for one byte through a raw pseudo-terminal and back."""
    master, slave = os.openpty()
    tty.setraw(slave)
    out = []
    try:
        for _ in range(samples):
            t0 = time.perf_counter()
            os.write(master, b"x")
            os.read(slave, 1)
            os.write(slave, b"y")
            os.read(master, 1)
            out.append(time.perf_counter() - t0)
    finally:
        os.close(master)
        os.close(slave)
    return out


def measure(firmware: str, moves: int) -> dict[str, list[float]]:
    """Latencies (wall seconds) of ``moves`` small moves on one firmware."""
    context = RigContext(profile=None, clock=WallClock())
    arm = dobot_v1_factory({"port": "sim", "firmware": firmware}, context)
    emu = context.shared[SHARED_KEY]
    arrivals: list[float] = []
    sends: list[float] = []
    handled: list[float] = []
    driver_share: list[float] = []
    lock = threading.Lock()

    on_bytes, send, on_data = emu.on_bytes, emu.send, arm.on_data

    def timed_on_bytes(data: bytes, t: float) -> None:
        with lock:
            arrivals.append(time.perf_counter())
        on_bytes(data, t)

    def timed_send(data: bytes) -> None:
        with lock:
            sends.append(time.perf_counter())
        send(data)

    def timed_on_data(data: bytes) -> None:
        t0 = time.perf_counter()
        before = arm.last_write_wall
        on_data(data)
        t1 = time.perf_counter()
        with lock:
            handled.append(t1)
            if arm.last_write_wall != before:
                driver_share.append(arm.last_write_wall - t0)

    emu.on_bytes, emu.send, arm.on_data = timed_on_bytes, timed_send, timed_on_data
    command, status = [], []
    try:
        arm.connect()
        rng = np.random.default_rng(0)
        for _ in range(moves):
            q = np.array([rng.uniform(-20, 20), rng.uniform(2, 10), rng.uniform(48, 55)])
            with lock:
                arrivals.clear()
                sends.clear()
                handled.clear()
            t0 = time.perf_counter()
            handle = arm.move_joints(q)
            handle.wait(10)
            with lock:
                first = next((t for t in arrivals if t >= t0), None)
                if first is not None:
                    command.append(first - t0)
                # each send is followed by the driver handling it
                for s in sends:
                    after = [h for h in handled if h >= s]
                    if after:
                        status.append(after[0] - s)
    finally:
        arm.close()
        for closer in reversed(context.closers):
            closer()
    return {"command": command, "status": status, "driver": driver_share}


def _ms(values: list[float]) -> str:
    if not values:
        return "-"
    return f"{1e3 * statistics.median(values):.3f} / {1e3 * np.percentile(values, 95):.3f}"


def main() -> None:
    """Measure both firmwares and print median / 95th percentile in milliseconds."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--moves", type=int, default=40)
    args = parser.parse_args()
    base = pty_round_trip()
    table = Table(title="Dobot V1 link latency, median / p95 ms (wall clock)")
    for col in ("figure", "original", "open-dobot"):
        table.add_column(col)
    results = {fw: measure(fw, args.moves) for fw in ("original", "open-dobot")}
    table.add_row("pty round trip (baseline)", _ms(base), _ms(base))
    table.add_row(
        "move() -> first byte at firmware",
        _ms(results["original"]["command"]),
        _ms(results["open-dobot"]["command"]),
    )
    table.add_row(
        "frame parsed -> command written (driver share)",
        _ms(results["original"]["driver"]),
        _ms(results["open-dobot"]["driver"]),
    )
    table.add_row(
        "status written -> handle updated",
        _ms(results["original"]["status"]),
        _ms(results["open-dobot"]["status"]),
    )
    Console().print(table)
    med = statistics.median(base)
    for fw, res in results.items():
        if res["status"]:
            ratio = statistics.median(res["status"]) / med
            print(f"{fw}: status-to-handle = {ratio:.1f}x the pty round trip; goal < 20 ms")


if __name__ == "__main__":
    main()
