"""Whole runs on a simulated bus-servo arm, from the command line, as a user starts them.

A servo that overheats or overloads mid-run ends ``run-tree load_ducky.yaml --rig
sim_so101`` (or sim_koch) with exit 3 and a message naming the servo; the run log
records the fault, and records how many status packets the bus lost (each asked
again) in its ``servo_bus`` event, as the summary's ``servo bus:`` line says.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

BIN = Path(sys.executable).parent
console = pytest.mark.skipif(
    not (BIN / "run-tree").exists(), reason="the armtree console scripts are not installed"
)

#: Status packets the emulator drops at the start of the run: replies to the first ping,
#: each asked for again (within the retry budget, 3 more asks, or the arm would not connect).
LOST = 2


def run_tree(tmp_path: Path, rig: str, fault: str, joint: int) -> subprocess.CompletedProcess:
    return subprocess.run(
        [
            str(BIN / "run-tree"), "load_ducky.yaml", "--rig", rig, "--quiet",
            "--record", "run", "--set", "planner={type: direct}",
            "--set", f"world.faults.{fault}.joint={joint}",
            "--set", f"world.faults.{fault}.after_s=3",
            "--set", f"world.faults.lost_replies.count={LOST}",
        ],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )  # fmt: skip


@console
@pytest.mark.parametrize(
    ("rig", "fault", "joint", "servo"),
    [
        ("sim_so101", "overheat", 2, "servo 3 (elbow_flex)"),
        ("sim_koch", "overload", 1, "servo 2 (shoulder_lift)"),
    ],
)
def test_a_tripped_servo_ends_the_run_with_exit_3_naming_it_and_the_log_counts_lost_packets(
    tmp_path, rig, fault, joint, servo
):
    done = run_tree(tmp_path, rig, fault, joint)
    said = done.stdout + done.stderr
    assert done.returncode == 3, said
    assert f"interrupted by {servo}: {fault}" in said
    assert f"{servo} reports {fault}: the arm is stopped and its torque off" in said
    assert f"servo bus: {LOST} status packets lost, each asked again" in said
    assert "Traceback" not in said

    records = [
        json.loads(line) for line in (tmp_path / "run" / "run.jsonl").read_text().splitlines()
    ]
    events = [r for r in records if r["kind"] == "event"]
    interrupt = next(e for e in events if e["event"] == "interrupt")
    assert interrupt["reason"] == f"{servo}: {fault}"
    assert any(e["event"] == "fault" and servo in e.get("error", "") for e in events)
    (bus,) = [e for e in events if e["event"] == "servo_bus"]
    assert bus["lost_status"] == LOST and bus["retries"] == 3
    assert bus["servos_heard"] == [1, 2, 3, 4, 5, 6]
    result = records[-1]
    assert result["kind"] == "result" and result["exit_code"] == 3
    assert servo in result["message"]
