"""Real signals and the stop key sent to a real ``run-tree`` process."""

import importlib.metadata
import os
import pty
import queue
import signal
import subprocess
import sys
import termios
import textwrap
import threading
import time
from pathlib import Path

import pytest

from armtree.runtime.runlog import read_log

RUN_TREE = Path(sys.executable).with_name("run-tree")

#: Only the core plugins: these tests are about interrupts, not about arms or skills.
ISOLATE = [
    arg
    for ep in importlib.metadata.entry_points(group="armtree")
    if ep.name not in ("core_behaviours", "core_commands")
    for arg in ("-p", f"no:{ep.name}")
]

#: Wall seconds a process may take to exit once told to: a bound against a hang, not a
#: measure of speed (a loaded machine takes seconds to tear a Python process down); how
#: fast the halt is, is asserted in ticks, from the run log.
EXIT_S = 30.0

SPIN = """\
tree: spin
tick_hz: 20
root:
  sequence:
    name: Root
    children:
      - success: {name: Ready}
      - running: {name: Wait}
"""

HANG_PLUGIN = '''
import threading
import armtree
from py_trees.common import Status


class Hang(armtree.Behaviour):
    """Never finishes, and its halt never returns."""

    def update(self):
        return Status.RUNNING

    def terminate(self, new_status):
        if new_status == Status.INVALID:
            threading.Event().wait()


@armtree.hookimpl
def armtree_behaviours():
    return {"hang": Hang}
'''


class Proc:
    """A run-tree subprocess whose stdout lines can be awaited with a timeout."""

    def __init__(self, args, cwd, stdin=None):
        self.p = subprocess.Popen(
            [str(RUN_TREE), *args, *ISOLATE],
            cwd=cwd,
            stdin=stdin if stdin is not None else subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.lines: queue.Queue = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.p.stdout:
            self.lines.put(line)
        self.lines.put(None)

    def wait_for(self, text, timeout=30.0):
        deadline = time.monotonic() + timeout
        seen = []
        while True:
            line = self.lines.get(timeout=max(0.01, deadline - time.monotonic()))
            if line is None:
                raise AssertionError(f"process ended before {text!r}: {''.join(seen)}")
            seen.append(line)
            if text in line:
                return line

    def finish(self, timeout):
        """Exit code and stderr; fails if the process is not gone within ``timeout`` s."""
        try:
            code = self.p.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.p.kill()
            raise
        return code, self.p.stderr.read()


@pytest.fixture
def spin(tmp_path):
    (tmp_path / "spin.yaml").write_text(SPIN)
    return tmp_path


@pytest.mark.parametrize(
    ("sig", "clock"),
    [
        (signal.SIGINT, "--realtime"),
        (signal.SIGTERM, "--seed=1"),
        # a closed terminal and Ctrl-\ stop a run as SIGTERM does (issue 32)
        (signal.SIGHUP, "--realtime"),
        (signal.SIGQUIT, "--seed=2"),
    ],
)
def test_a_signal_halts_a_real_run_and_exits_130_with_the_log_flushed(spin, sig, clock):
    proc = Proc(["spin.yaml", "--record", "rec", clock], spin)
    proc.wait_for("Root/Wait: INVALID -> RUNNING")
    proc.p.send_signal(sig)
    code, err = proc.finish(timeout=EXIT_S)
    assert code == 130, err
    name = sig.name
    assert f"interrupted by {name}" in err and "Root/Wait" in err
    log = read_log(spin / "rec" / "run.jsonl")
    result = log[-1]
    assert result["kind"] == "result" and result["status"] == "INTERRUPTED"
    assert result["running"] == ["Root/Wait"]
    (seen,) = [r for r in log if r.get("event") == "interrupt"]
    assert seen["reason"] == name
    # Halted within the tick that saw the signal: no tick after it, and every node that
    # ran was stopped (INVALID) in that same tick.
    assert result["ticks"] == seen["tick"]
    halted = [r for r in log if r["kind"] == "status" and r["to"] == "INVALID"]
    assert {r["node"] for r in halted} == {"Root", "Root/Ready", "Root/Wait"}
    assert {r["tick"] for r in halted} == {seen["tick"]}


def test_a_second_sigint_during_a_hanging_halt_forces_exit(spin):
    (spin / "hang.py").write_text(textwrap.dedent(HANG_PLUGIN))
    (spin / "hang.yaml").write_text("tree: hang\nroot:\n  hang: {name: Stuck}\n")
    proc = Proc(["hang.yaml", "--plugin", "hang.py", "--record", "rec", "--realtime"], spin)
    proc.wait_for("Stuck: INVALID -> RUNNING")
    proc.p.send_signal(signal.SIGINT)
    proc.wait_for("interrupted: SIGINT")
    proc.p.send_signal(signal.SIGINT)
    # The halt never returns, so only the forced exit can end the process.
    code, err = proc.finish(timeout=EXIT_S)
    assert code == 130 and "forced exit" in err
    log = read_log(spin / "rec" / "run.jsonl")
    assert log[-1]["event"] == "forced_exit"


def test_the_stop_key_in_a_terminal_halts_the_run(spin):
    master, slave = pty.openpty()
    try:
        proc = Proc(["spin.yaml", "--record", "rec", "--realtime"], spin, stdin=slave)
        proc.wait_for("Root/Wait: INVALID -> RUNNING")
        os.write(master, b"q")
        code, err = proc.finish(timeout=EXIT_S)
    finally:
        os.close(slave)
        os.close(master)
    assert code == 130 and "interrupted by stop key" in err
    assert read_log(spin / "rec" / "run.jsonl")[-1]["status"] == "INTERRUPTED"


def test_a_forced_exit_gives_the_terminal_back(spin):
    (spin / "hang.py").write_text(textwrap.dedent(HANG_PLUGIN))
    (spin / "hang.yaml").write_text("tree: hang\nroot:\n  hang: {name: Stuck}\n")
    master, slave = pty.openpty()
    try:
        before = termios.tcgetattr(slave)
        args = ["hang.yaml", "--plugin", "hang.py", "--record", "rec", "--realtime"]
        proc = Proc(args, spin, stdin=slave)
        proc.wait_for("Stuck: INVALID -> RUNNING")
        assert termios.tcgetattr(slave) != before  # cbreak mode for the stop key
        proc.p.send_signal(signal.SIGINT)
        proc.wait_for("interrupted: SIGINT")
        proc.p.send_signal(signal.SIGINT)
        code, _ = proc.finish(timeout=EXIT_S)
        assert code == 130
        assert termios.tcgetattr(slave) == before
    finally:
        os.close(slave)
        os.close(master)


LOOP = """\
rig: sim_dobot
root:
  repeat:
    num_success: 1000
    child:
      sequence:
        - move_to: {to: garbage_bin}
        - move_to: {to: home}
"""


def test_a_paused_realtime_run_is_no_link_fault(tmp_path):
    """Issue 32: SIGSTOP and SIGCONT (Ctrl-Z and fg) mid-motion under --realtime; the
    driver notices the pause and reads the arm again, so the run goes on to its timeout."""
    (tmp_path / "loop.yaml").write_text(LOOP)
    # Not Proc: it blocks the arm plugins, and this run needs the simulated arm.
    proc = subprocess.Popen(
        [str(RUN_TREE), "loop.yaml", "--realtime", "--timeout", "5", "--record", "rec"],
        cwd=tmp_path,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 30
    while not (tmp_path / "rec" / "run.jsonl").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(1.5)  # moving by now
    proc.send_signal(signal.SIGSTOP)
    time.sleep(2.0)
    proc.send_signal(signal.SIGCONT)
    try:
        code = proc.wait(timeout=30)
    finally:
        proc.kill()
    err = proc.stderr.read()
    assert "link lost" not in err and "hardware fault" not in err, err
    records = read_log(tmp_path / "rec" / "run.jsonl")
    result = records[-1]
    assert result["kind"] == "result" and "timeout" in result.get("message", ""), result
    assert code == 1, err
    pauses = [r for r in records if r.get("event") == "process_paused"]
    assert len(pauses) == 1, [r for r in records if r.get("kind") == "event"]
    assert 1.5 < pauses[0]["wall_s"] < 10.0, pauses[0]
