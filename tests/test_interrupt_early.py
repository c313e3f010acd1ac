"""Ctrl-C and SIGTERM while a command is still starting: exit 130, one line, no traceback."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

RUN_TREE = Path(sys.executable).with_name("run-tree")


def test_an_interrupt_during_the_first_imports_exits_130_quietly() -> None:
    # What the console script does first, then a signal while heavy modules would load.
    code = (
        "import os, signal, armtree.cli.console\n"
        "os.kill(os.getpid(), signal.SIGINT)\n"
        "import time; time.sleep(5)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 130
    assert done.stderr.strip() == "interrupted while starting"


def test_importing_armtree_loads_nothing_heavy() -> None:
    # The console script holds Ctrl-C only once armtree is imported: that must be quick.
    code = "import sys, armtree.cli.console; print(sorted({'numpy', 'py_trees', 'yaml'} & set(sys.modules)))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "[]"


SLOW_PLUGIN = """
import pathlib, time
pathlib.Path("loading").touch()
time.sleep(30)
"""


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupt_while_a_tree_loads_exits_130_without_a_traceback(
    tmp_path: Path, sig: signal.Signals
) -> None:
    (tmp_path / "slow.py").write_text(SLOW_PLUGIN)
    (tmp_path / "t.yaml").write_text("plugins: [./slow.py]\nroot: {success: {}}\n")
    proc = subprocess.Popen(
        [str(RUN_TREE), "t.yaml", "--record", "rec"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 60
    while not (tmp_path / "loading").exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    proc.send_signal(sig)
    try:
        out, err = proc.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert err.strip().endswith("interrupted")
    assert not (tmp_path / "rec").exists()  # nothing ran, nothing was written


def test_two_quick_ctrl_cs_always_exit_130(tmp_path: Path) -> None:
    # The second SIGINT lands while the first one unwinds the run, or after the command
    # returned; it once escaped every handler (a traceback, or death by the signal).
    (tmp_path / "t.yaml").write_text(
        "root: {tick_counter: {duration: 100000, completion_status: SUCCESS}}\n"
    )
    procs = []
    for n, gap_s in enumerate((0.0, 0.001, 0.01, 0.05)):
        folder = tmp_path / f"run{n}"
        folder.mkdir()
        proc = subprocess.Popen(
            [str(RUN_TREE), "../t.yaml", "--realtime", "--quiet", "--record", "rec"],
            cwd=folder,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        procs.append((proc, folder, gap_s))
    for proc, folder, gap_s in procs:
        deadline = time.monotonic() + 60
        while not (folder / "rec" / "run.jsonl").exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        proc.send_signal(signal.SIGINT)
        time.sleep(gap_s)
        proc.send_signal(signal.SIGINT)
    for proc, _, gap_s in procs:
        _, err = proc.communicate(timeout=30)
        assert proc.returncode == 130, (gap_s, err)
        assert "Traceback" not in err, err
