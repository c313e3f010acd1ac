"""The PyPI client pydobot 1.3.2 drives the Magician emulator as it would the arm.

pydobot sleeps 0.1 s around every command and reads whatever arrived as one
reply, so the emulator runs on the wall clock here (as under ``armtree
emulate``) and the client runs on a thread bounded by a timeout.
"""

from __future__ import annotations

import threading

import numpy as np
import pytest

from armtree.api.clock import WallClock
from armtree.plugins.arms.dobot_magician.plugin import magician_factory

pydobot = pytest.importorskip("pydobot", reason="pydobot 1.3.2 is in the test extra")


@pytest.fixture(autouse=True)
def patient_pydobot(monkeypatch):
    """pydobot reads one reply 0.1 s after each command: on a loaded machine (CI on two
    shared cores) the emulator's thread may not have answered yet, and pydobot then
    fails on a missing reply. Here it reads again, up to 5 s, for the same reply:
    the bytes on the wire are what is tested, not the machine's latency."""
    read = pydobot.dobot.Dobot._read_message

    def patient(self):
        for _ in range(50):
            msg = read(self)
            if msg is not None:
                return msg
        return None

    monkeypatch.setattr(pydobot.dobot.Dobot, "_read_message", patient)


def run_bounded(fn, timeout: float):
    result: dict = {}

    def target():
        try:
            result["value"] = fn()
        except Exception as exc:  # reported below with the test's own assertion
            result["error"] = exc

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(timeout)
    assert not thread.is_alive(), f"pydobot did not finish within {timeout} s"
    if "error" in result:
        raise result["error"]
    return result["value"]


def test_pydobot_connects_reads_pose_moves_with_wait_and_switches_suction():
    emulator = magician_factory.emulator({}, WallClock())
    path = emulator.start()
    try:
        device = run_bounded(lambda: pydobot.Dobot(port=path), 10.0)
        try:
            pose = run_bounded(device.pose, 5.0)
            expected = emulator.model.pose_xyzr(emulator.model.home)
            np.testing.assert_allclose(pose[:4], expected, atol=1e-3)
            np.testing.assert_allclose(pose[4:], emulator.model.home, atol=1e-3)

            run_bounded(lambda: device.move_to(220.0, 30.0, 20.0, 0.0, wait=True), 20.0)
            # wait=True returned only once the queue index reached the move: it is there
            np.testing.assert_allclose(
                emulator.model.position(emulator.true_joints()), [220.0, 30.0, 20.0], atol=1e-3
            )
            pose = run_bounded(device.pose, 5.0)
            np.testing.assert_allclose(pose[:3], [220.0, 30.0, 20.0], atol=1e-3)

            run_bounded(lambda: device.suck(True), 5.0)
            run_bounded(lambda: device.wait(200), 5.0)  # queued after the suction command
            deadline = threading.Event()
            for _ in range(50):
                if emulator.tool().suction:
                    break
                deadline.wait(0.05)
            assert emulator.tool().suction
        finally:
            run_bounded(device.close, 5.0)
    finally:
        emulator.close()
    assert emulator.parser.bad_checksums == 0


def test_pydobot_through_armtree_emulate():
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    # This interpreter's own console script first: another armtree earlier on PATH (a
    # global install) is not the one under test.
    own = Path(sys.executable).with_name("armtree")
    exe = str(own) if own.exists() else shutil.which("armtree")
    proc = subprocess.Popen(
        [exe, "emulate", "dobot_magician"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        path = run_bounded(proc.stdout.readline, 20.0).strip()
        assert path.startswith("/dev/")
        device = run_bounded(lambda: pydobot.Dobot(port=path), 10.0)
        try:
            pose = run_bounded(device.pose, 5.0)
            model = magician_factory.model({})
            np.testing.assert_allclose(pose[4:], model.home, atol=1e-3)
        finally:
            run_bounded(device.close, 5.0)
    finally:
        proc.terminate()
        assert proc.wait(timeout=10) == 130, "an interrupted emulator exits 130"
