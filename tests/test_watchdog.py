"""The tick watchdog: a tick that never returns is a fault (exit 3), and the first
interrupt stops a run whatever its tick is doing (exit 130)."""

from __future__ import annotations

import importlib.metadata
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import py_trees
import pytest
from hostile_corpus import STUCK_PLUGIN
from py_trees.common import Status

import armtree
from armtree.api.clock import VirtualClock
from armtree.api.rig import Rig
from armtree.loader.tree import Tree
from armtree.runtime.runlog import read_log
from armtree.runtime.runner import run

RUN_TREE = Path(sys.executable).with_name("run-tree")


class Spin(py_trees.behaviour.Behaviour):
    """Busy-loops in its first update, for ever."""

    def update(self) -> Status:
        while True:
            pass


class Holder(py_trees.behaviour.Behaviour):
    """RUNNING for ever: the object it holds must be kept when the run stops."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.halted = False

    def update(self) -> Status:
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        self.halted = self.halted or new_status == Status.INVALID


class StopRecorder:
    """An arm that records from which thread it was told to stop."""

    device = "fake arm"

    def __init__(self) -> None:
        self.stops: list[str] = []

    def stop(self) -> None:
        self.stops.append(threading.current_thread().name)

    def request_stop(self) -> None:
        threading.Thread(target=self.stop, name="driver thread").start()


def stuck_tree() -> tuple[Tree, Holder]:
    holder = Holder("Hold")
    root = py_trees.composites.Parallel(
        "Root",
        policy=py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=False),
        children=[holder, Spin("Stuck")],
    )
    return Tree(name="stuck", root=root, source=None), holder


def test_an_overrun_tick_ends_the_run_with_exit_3_naming_the_node() -> None:
    tree, holder = stuck_tree()
    arm = StopRecorder()
    rig = Rig(profile=None, clock=VirtualClock(), arm=arm)
    start = time.monotonic()
    result = run(tree, rig=rig, record=False, handle_signals=False, tick_limit=0.3)
    assert time.monotonic() - start < 5.0
    assert result.exit_code == 3
    assert "watchdog's 0.3 s" in result.message
    assert "Root/Stuck" in result.message
    assert result.failed_node == "Root/Stuck"
    assert holder.halted
    # Told to stop from the driver's side while the run's thread was stuck, then again
    # by the run's own stop.
    assert arm.stops[0] == "driver thread"


def test_an_interrupt_during_a_stuck_tick_starts_the_safe_stop(tmp_path: Path) -> None:
    tree, holder = stuck_tree()
    rig = Rig(profile=None, clock=VirtualClock(), arm=StopRecorder())
    runner = armtree.Run(tree, rig, record=tmp_path, handle_signals=False, tick_limit=60.0)
    threading.Timer(0.3, runner.interrupt, args=("test stop",)).start()
    start = time.monotonic()
    result = runner.execute()
    assert time.monotonic() - start < 5.0
    assert (result.status, result.exit_code) == ("INTERRUPTED", 130)
    assert "Root/Stuck" in result.message and "did not return" in result.message
    assert holder.halted
    records = read_log(tmp_path / "run.jsonl")
    assert any(r.get("event") == "interrupt" for r in records)
    assert records[-1]["kind"] == "result"


def test_a_profile_sets_the_limit_and_refuses_a_bad_one(tmp_path: Path) -> None:
    profile = tmp_path / "p.yaml"
    profile.write_text("arm: {type: dobot_v1}\nwatchdog: {tick_s: 0}\n")
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile(profile)
    assert (info.value.line, info.value.column) == (2, 20)
    assert "watchdog.tick_s" in info.value.message


#: Only the core plugins: these runs are about signals, not arms or skills.
ISOLATE = [
    arg
    for ep in importlib.metadata.entry_points(group="armtree")
    if ep.name not in ("core_behaviours", "core_commands")
    for arg in ("-p", f"no:{ep.name}")
]


@pytest.mark.parametrize(
    ("node", "sig"), [("spin_forever", signal.SIGINT), ("sleep_forever", signal.SIGTERM)]
)
def test_the_first_signal_stops_a_real_run_stuck_in_a_tick(
    tmp_path: Path, node: str, sig: signal.Signals
) -> None:
    (tmp_path / "stuck.py").write_text(STUCK_PLUGIN)
    (tmp_path / "t.yaml").write_text(
        textwrap.dedent(
            f"""\
            tree: stuck
            plugins: [./stuck.py]
            root:
              sequence:
                name: Root
                children:
                  - tick_counter: {{name: Warm, duration: 3, completion_status: SUCCESS}}
                  - {node}: {{name: Stuck}}
            """
        )
    )
    proc = subprocess.Popen(
        [str(RUN_TREE), "t.yaml", "--record", "rec", *ISOLATE],
        cwd=tmp_path,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 60
    while not (tmp_path / "stuck").exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    time.sleep(0.3)  # well inside the stuck tick
    sent = time.monotonic()
    proc.send_signal(sig)
    try:
        code = proc.wait(timeout=5.0)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    assert time.monotonic() - sent < 5.0
    err = proc.stderr.read() if proc.stderr else ""
    assert code == 130, err
    assert "Traceback" not in err
    assert "Root/Stuck" in err and "did not return" in err
    records = read_log(tmp_path / "rec" / "run.jsonl")
    assert records[-1]["kind"] == "result" and records[-1]["exit_code"] == 130
