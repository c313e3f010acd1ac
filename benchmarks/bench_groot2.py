"""The Groot2 server's cost per tick (run-tree --groot2).

The same simulated run (same tree, same seed) at 20 Hz in real time, with ``--groot2``
and a client polling it as Groot2 does (another process: the tree once, the status
buffer 20 times a second, the blackboard twice a second), and without (paced the
same way), alternating, several rounds. Reported as bench_monitor.py reports the
browser monitor's: the run thread's mean tick work (wall ms between two ticks'
sleeps, the hook that takes each tick's statuses included) and the run process's
CPU time per tick (every thread: the server's too), with and without, and the
difference as a share of the 50 ms tick; and, steadier on a loaded machine, the time
the tick hook and the request handler take where they run. Goal: < 3 %.

Usage: python benchmarks/bench_groot2.py [--tree pick_and_place.yaml] [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

from bench_monitor import TickTimes, execute_paced, print_cost

from armtree.cli.run_command import plugin_manager_for
from armtree.loader.tree_loader import load_tree
from armtree.runtime.runner import Run

#: The client, in a process of its own so its CPU is not charged to the run's.
CLIENT_SCRIPT = """
import struct, sys, time, zmq
port = int(sys.argv[1])
context = zmq.Context()
socket = context.socket(zmq.REQ)
socket.setsockopt(zmq.RCVTIMEO, 2000)
socket.connect(f"tcp://127.0.0.1:{port}")
def ask(kind, *extra):
    socket.send_multipart([struct.pack("<BBI", 2, ord(kind), 1), *extra])
    return socket.recv_multipart()
ask("T")
print("ready", flush=True)
n = 0
start = time.monotonic()
while True:
    try:
        ask("S")
        if n % 10 == 0:
            ask("B", b"")
    except zmq.Again:
        break
    n += 1
    time.sleep(max(0.0, start + n / 20 - time.monotonic()))
print(n, flush=True)
"""


def one_run(tree_name: str, seed: int, served: bool) -> dict:
    manager = plugin_manager_for(None, None)
    times = TickTimes()
    manager.register(times, "bench_tick_times")
    tree = load_tree(tree_name, manager=manager)
    run = Run(
        tree,
        seed=seed,
        manager=manager,
        record=False,
        quiet=True,
        settings={"groot2": 0} if served else {},
    )
    client: subprocess.Popen | None = None
    spent = {"tick": [0.0, 0], "reply": [0.0, 0]}

    def timed(what: str, call):
        def wrapper(*args):
            t0 = time.perf_counter()
            try:
                return call(*args)
            finally:
                spent[what][0] += time.perf_counter() - t0
                spent[what][1] += 1

        return wrapper

    if served:
        # The client connects once the server is up; the run waits (paused) for it.
        run.control.pause()

        def watch() -> None:
            nonlocal client
            session = None
            while session is None or session.tree is None:
                time.sleep(0.01)
                session = run.plugin_state.get("btcpp.groot2")
            # the hook's and the server thread's own time, measured where they run
            session.tick = timed("tick", session.tick)
            session.server.reply = timed("reply", session.server.reply)
            client = subprocess.Popen(
                [sys.executable, "-c", CLIENT_SCRIPT, str(session.server.port)],
                stdout=subprocess.PIPE,
                text=True,
            )
            assert client.stdout is not None
            client.stdout.readline()  # "ready"
            run.control.resume()

    result, cpu = execute_paced(run, watch if served else None)
    manager.pm.unregister(times)
    polls = 0
    if client is not None:
        out, _ = client.communicate(timeout=30)
        polls = int(out.strip().splitlines()[-1])
    return {
        "ticks": result.ticks,
        "status": result.status,
        "tick_ms": 1000 * statistics.fmean(times.walls),
        "cpu_ms_per_tick": 1000 * cpu / max(1, result.ticks),
        "overruns": result.overruns,
        "polls": polls,
        "hook_us": 1e6 * spent["tick"][0] / max(1, spent["tick"][1]),
        "reply_us": 1e6 * spent["reply"][0] / max(1, spent["reply"][1]),
        "tick_hz": run.tick_hz,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tree", default="pick_and_place.yaml", help="tree for the runs")
    parser.add_argument("--rounds", type=int, default=3, help="runs with and without, each")
    args = parser.parse_args()
    results: dict[bool, list[dict]] = {False: [], True: []}
    for r in range(args.rounds):
        for served in (False, True) if r % 2 == 0 else (True, False):
            res = one_run(args.tree, 0, served)
            results[served].append(res)
            what = "--groot2 + client" if served else "no server       "
            print(
                f"  round {r + 1} {what}: {res['ticks']} ticks {res['status']}, tick work "
                f"{res['tick_ms']:.2f} ms, process CPU {res['cpu_ms_per_tick']:.2f} ms/tick, "
                f"overruns {res['overruns']}, status polls answered {res['polls']}"
                + (
                    f", hook {res['hook_us']:.1f} us/tick, reply {res['reply_us']:.1f} us/request"
                    if served
                    else ""
                ),
                flush=True,
            )
    print_cost(args.tree, args.rounds, results)
    period_ms = 1000 / results[True][0]["tick_hz"]
    hook = statistics.median(r["hook_us"] for r in results[True])
    reply = statistics.median(r["reply_us"] for r in results[True])
    print(
        f"measured where they run: the tick hook {hook:.1f} us a tick, a request answered in "
        f"{reply:.1f} us; at 20 polls a second {100 * (hook + reply * 1.1) / 1000 / period_ms:.2f} "
        "% of the tick"
    )


if __name__ == "__main__":
    main()
