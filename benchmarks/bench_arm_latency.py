"""Link latencies of the Magician, VICRA and DH (SSC-32) drivers against their emulators.

Run: ``python benchmarks/bench_arm_latency.py [--seconds 3]``. Each arm runs
as with ``--realtime``: the emulator serves its pseudo-terminal on the wall
clock and the real driver talks to it through pyserial while polling.

* command latency: from a behaviour's ``move_joints()`` call to the command's
  first byte written to the port (the driver may first have to wait for the
  reply to a poll already in flight);
* status-to-state latency: from the emulator writing a joint report to the
  driver holding the parsed joints (what a behaviour reads into the
  blackboard on its next tick).

Goal (issue 3): both under one tick at 50 Hz (20 ms). Baseline in the same
run: the pseudo-terminal's own round trip (a byte written on one side, read
on the other), the floor every figure stands on.
"""

from __future__ import annotations

import argparse
import os
import statistics
import threading
import time
import tty

import numpy as np
import yaml
from rich.console import Console
from rich.table import Table

from armtree.clock import WallClock
from armtree.rig import RigContext

ARMS = ("dobot_magician", "vicra", "dh")


def pty_round_trip(samples: int = 200) -> list[float]:
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
    from armtree.plugin_manager import get_plugin_manager

    return get_plugin_manager().registry.get("arm", arm).factory


def measure(arm: str, seconds: float) -> tuple[list[float], list[float]]:
    """Command latencies and status-to-state latencies (wall seconds) of one arm."""
    context = RigContext(profile=None, clock=WallClock())
    driver = factory_for(arm)(config_for(arm), context)
    emulator = context.shared["sim.arm"]
    sends: list[float] = []
    send = emulator.send

    def timed_send(data: bytes) -> None:
        sends.append(time.perf_counter())
        send(data)

    emulator.send = timed_send  # the benchmark's probe on the emulator's writes
    try:
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
    finally:
        driver.close()
        for closer in reversed(context.closers):
            closer()


def main() -> None:
    """Measure every arm and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="measuring time per arm")
    args = parser.parse_args()
    floor = pty_round_trip()
    table = Table(title="Link latency on the wall clock (ms): median / 95th percentile / max")
    for col in ("arm", "command -> first byte", "status -> driver state", "samples"):
        table.add_column(col)

    def fmt(values: list[float]) -> str:
        if not values:
            return "-"
        ms = np.array(values) * 1000.0
        return f"{np.median(ms):.3f} / {np.percentile(ms, 95):.3f} / {ms.max():.3f}"

    table.add_row("pty round trip (baseline)", fmt(floor), "", str(len(floor)))
    for arm in ARMS:
        command, status = measure(arm, args.seconds)
        table.add_row(arm, fmt(command), fmt(status), f"{len(command)} / {len(status)}")
    Console(width=160).print(table)
    print(f"goal: under one tick at 50 Hz (20 ms); threads alive: {threading.active_count()}")
    print(f"pty round trip median {statistics.median(floor) * 1e3:.3f} ms")


if __name__ == "__main__":
    main()
