"""Link latencies of every arm's driver against its emulator, on the wall clock.

Run: ``python benchmarks/bench_arm_latency.py [--seconds 3] [--moves 40]``.
Each arm runs as with ``--realtime``: the emulator serves its pseudo-terminal
on the wall clock and the real pyserial driver talks to it.

Magician, VICRA and DH (SSC-32), whose drivers poll (``--seconds`` of moves each):

* command latency: from a behaviour's ``move_joints()`` call to the command's
  first byte written to the port (the driver may first have to wait for the
  reply to a poll already in flight);
* status-to-state latency: from the emulator writing a joint report to the
  driver holding the parsed joints (what a behaviour reads into the
  blackboard on its next tick).

Dobot V1, original and open-dobot firmware (``--moves`` small moves each):

* command latency: from ``move_joints()`` returning to the command's first byte
  read by the firmware. The original firmware's protocol makes the host wait for
  the next status frame (one command per status frame, 50 ms period), so the
  driver's own share is reported too: from a status frame being parsed to the
  queued command written;
* status-to-handle latency: from the emulator writing a status frame (original)
  or a GET_COUNTERS reply (open-dobot) to the driver having parsed it and updated
  the motion handles (what a behaviour reads on its next tick).

Goal (issue 3): under one tick at 50 Hz (20 ms). Baseline in the same run: the
pseudo-terminal's own round trip (a byte written on one side, read on the
other), the floor every figure stands on.
"""

from __future__ import annotations

import argparse
import os
import statistics
import threading
import time
import tty
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import yaml
from rich.console import Console
from rich.table import Table

from armtree.api.clock import WallClock
from armtree.api.emulation import SHARED_KEY
from armtree.api.rig import RigContext
from armtree.plugins.arms.dobot_v1.plugin import dobot_v1_factory

ARMS = ("dobot_magician", "vicra", "dh")
DOBOT_V1_FIRMWARES = ("original", "open-dobot")


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


def config_for(arm: str) -> dict:
    """A profile's arm section for each arm (the shipped PUMA 560 for dh)."""
    if arm == "dh":
        from armtree.hardware import __file__ as hw

        path = os.path.join(os.path.dirname(hw), "dh_puma560.yaml")
        with open(path, encoding="utf-8") as fh:
            return {**yaml.safe_load(fh)["arm"], "port": "sim"}
    return {"type": arm, "port": "sim"}


def factory_for(arm: str):
    """The arm's registered factory."""
    from armtree.hooks.plugin_manager import get_plugin_manager

    return get_plugin_manager().registry.get("arm", arm).factory


@contextmanager
def wall_clock_arm(factory: Callable[[dict, RigContext], Any], config: dict) -> Iterator[tuple]:
    """``(driver, emulator)`` of ``factory`` on ``port: sim`` served on the wall clock; closed after."""
    context = RigContext(profile=None, clock=WallClock())
    driver = factory(config, context)
    try:
        yield driver, context.shared[SHARED_KEY]
    finally:
        driver.close()
        for closer in reversed(context.closers):
            closer()


def measure_polled(arm: str, seconds: float) -> tuple[list[float], list[float]]:
    """Command latencies and status-to-state latencies (wall seconds) of one arm."""
    with wall_clock_arm(factory_for(arm), config_for(arm)) as (driver, emulator):
        return _polled_latencies(arm, driver, emulator, seconds)


def _polled_latencies(arm: str, driver, emulator, seconds: float) -> tuple[list, list]:
    """Connect ``driver``, move it to and fro around home for ``seconds`` and time the link."""
    sends: list[float] = []
    send = emulator.send

    def timed_send(data: bytes) -> None:
        sends.append(time.perf_counter())
        send(data)

    emulator.send = timed_send  # the benchmark's probe on the emulator's writes
    driver.connect()
    if arm == "vicra":
        deadline = time.monotonic() + 30.0
        while not driver.settled and time.monotonic() < deadline:
            time.sleep(0.01)
    home = driver.model.home
    driver.move_joints(home).wait(30.0)  # start at home: the measured moves are short
    span = driver.model.upper - driver.model.lower
    command, status = [], []
    end = time.monotonic() + seconds
    seen = driver.status_wall
    k = 0
    while time.monotonic() < end:
        k += 1
        target = home + np.where(np.arange(driver.model.dof) == 1, 0.02 * span * (k % 2), 0.0)
        t0 = time.perf_counter()
        handle = driver.move_joints(target, speed=1.0)
        while driver.last_write_wall < t0 and not handle.done:
            time.sleep(0.0002)
        if driver.last_write_wall >= t0:
            command.append(driver.last_write_wall - t0)
        # status samples while the move runs
        stop = time.monotonic() + 0.1
        while time.monotonic() < stop:
            if driver.status_wall != seen:
                seen = driver.status_wall
                before = [s for s in sends if s <= seen]
                if before:
                    status.append(seen - before[-1])
            time.sleep(0.0005)
        handle.wait(2.0)
    return command, status


def measure_dobot_v1(firmware: str, moves: int) -> dict[str, list[float]]:
    """Latencies (wall seconds) of ``moves`` small moves on one firmware."""
    with wall_clock_arm(dobot_v1_factory, {"port": "sim", "firmware": firmware}) as (arm, emu):
        return _dobot_v1_latencies(arm, emu, moves)


def _dobot_v1_latencies(arm, emu, moves: int) -> dict[str, list[float]]:
    """Connect ``arm``, make ``moves`` small random moves and time the link."""
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
    return {"command": command, "status": status, "driver": driver_share}


def _ms(values: list[float], with_max: bool = False) -> str:
    """Median / 95th percentile (/ max) in milliseconds, or "-" without samples."""
    if not values:
        return "-"
    ms = np.array(values) * 1000.0
    text = f"{np.median(ms):.3f} / {np.percentile(ms, 95):.3f}"
    return f"{text} / {ms.max():.3f}" if with_max else text


def polled_table(floor: list[float], seconds: float) -> Table:
    """The Magician, VICRA and DH figures, one row per arm."""
    table = Table(title="Link latency on the wall clock (ms): median / 95th percentile / max")
    for col in ("arm", "command -> first byte", "status -> driver state", "samples"):
        table.add_column(col)
    table.add_row("pty round trip (baseline)", _ms(floor, True), "", str(len(floor)))
    for arm in ARMS:
        command, status = measure_polled(arm, seconds)
        table.add_row(arm, _ms(command, True), _ms(status, True), f"{len(command)} / {len(status)}")
    return table


def dobot_v1_table(floor: list[float], moves: int) -> tuple[Table, dict[str, dict]]:
    """The Dobot V1 figures, one column per firmware, and the measured latencies."""
    table = Table(title="Dobot V1 link latency, median / p95 ms (wall clock)")
    for col in ("figure", *DOBOT_V1_FIRMWARES):
        table.add_column(col)
    results = {fw: measure_dobot_v1(fw, moves) for fw in DOBOT_V1_FIRMWARES}
    table.add_row("pty round trip (baseline)", *(_ms(floor) for _ in DOBOT_V1_FIRMWARES))
    for figure, key in (
        ("move() -> first byte at firmware", "command"),
        ("frame parsed -> command written (driver share)", "driver"),
        ("status written -> handle updated", "status"),
    ):
        table.add_row(figure, *(_ms(results[fw][key]) for fw in DOBOT_V1_FIRMWARES))
    return table, results


def main() -> None:
    """Measure every arm and print the tables and the ratios to the pty round trip."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="measuring time per polled arm")
    parser.add_argument("--moves", type=int, default=40, help="moves per Dobot V1 firmware")
    args = parser.parse_args()
    floor = pty_round_trip()
    console = Console(width=160)
    console.print(polled_table(floor, args.seconds))
    table, results = dobot_v1_table(floor, args.moves)
    console.print(table)
    med = statistics.median(floor)
    for fw, res in results.items():
        if res["status"]:
            ratio = statistics.median(res["status"]) / med
            print(f"{fw}: status-to-handle = {ratio:.1f}x the pty round trip; goal < 20 ms")
    print(f"goal: under one tick at 50 Hz (20 ms); threads alive: {threading.active_count()}")
    print(f"pty round trip median {med * 1e3:.3f} ms")


if __name__ == "__main__":
    main()
