"""Bad hardware input on the real-hardware path: each a HardwareFault naming the device.

The shipped ``dobot_v1.yaml`` is run with its port and camera pointed at what a
user might get wrong: a port that is not there, a regular file, /dev/null, the
wrong arm's firmware, a camera index that does not exist, a stream that stops
mid-run. Each run ends with exit 3, a message naming the device and what was
expected, the arm told to stop where it was connected, and the run log's result
record written. ``armtree detect-port --probe`` tells which emulated arm is on
which pty.
"""

import json
import threading
import time

import numpy as np
import pytest

import armtree
from armtree.api.clock import WallClock
from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.plugins.arms.detect import PROBES, probe_port
from armtree.plugins.arms.dobot_v1 import codec
from armtree.plugins.sim.mjpeg import MjpegServer

#: The planner is not under test: a straight-line one keeps each run short.
FAST = ("planner={type: direct}",)


def emulator(profile: str):
    """The firmware emulator of a shipped profile's arm, served on a pty on the wall clock."""
    manager = get_plugin_manager()
    config = dict(armtree.load_profile(profile, manager=manager).component("arm"))
    factory = manager.registry.get("arm", config["type"]).factory
    emu = factory.emulator(config, WallClock())
    emu.start()
    return emu


def run_dobot(tmp_path, *overrides, tree="load_ducky.yaml", rig="dobot_v1.yaml"):
    loaded = armtree.load_tree(tree, rig=rig, overrides=[*FAST, *overrides])
    return armtree.run(
        loaded, record=tmp_path / "run", handle_signals=False, stop_key=False, timeout=30.0
    )


def logged_result(tmp_path) -> dict:
    lines = (tmp_path / "run" / "run.jsonl").read_text().splitlines()
    return json.loads(lines[-1])


def stopped(emu, wait: float = 2.0) -> bool:
    """True once the Dobot V1.0 emulator has received a jog-stop frame (its thread reads
    the pty every few milliseconds, so the bytes may still be on their way)."""
    stop = codec.jog(codec.AXIS_STOP).encode()
    deadline = time.monotonic() + wait
    while time.monotonic() < deadline:
        if stop in b"".join(data for _, way, data in list(emu.transcript) if way == "rx"):
            return True
        time.sleep(0.02)
    return False


@pytest.fixture
def dobot():
    emu = emulator("dobot_v1")
    yield emu
    emu.close()


@pytest.fixture
def stream():
    server = MjpegServer()
    server.start()
    alive = threading.Event()
    alive.set()

    def publish():
        while alive.is_set():
            server.publish(np.full((480, 640, 3), 128, np.uint8))
            time.sleep(1 / 30)

    thread = threading.Thread(target=publish, daemon=True)
    thread.start()
    yield server, alive
    alive.clear()
    thread.join()
    server.close()


@pytest.mark.parametrize(
    ("port", "expected"),
    [
        ("/dev/ttyUSB_unplugged", "no such serial port (is the arm plugged in"),
        ("/dev/null", "not a serial port: a device that is not a terminal"),
        ("REGULAR", "not a serial port: it is a regular file"),
    ],
    ids=["unplugged", "dev-null", "regular-file"],
)
def test_a_port_that_is_no_serial_port_is_a_fault_naming_it(tmp_path, port, expected):
    if port == "REGULAR":
        port = str(tmp_path / "notes.txt")
        (tmp_path / "notes.txt").write_text("not a tty\n")
    result = run_dobot(tmp_path, f"arm.port={port}")
    assert (result.status, result.exit_code, result.ticks) == ("FAILURE", 3, 0)
    assert f"{port}: {expected}" in result.message
    assert logged_result(tmp_path)["exit_code"] == 3


def test_the_wrong_arm_on_the_port_is_a_fault_saying_what_was_expected(tmp_path, dobot):
    result = run_dobot(tmp_path, f"arm.port={dobot.path}", rig="dobot_magician.yaml")
    assert result.exit_code == 3 and result.ticks == 0
    assert f"{dobot.path}: wrong protocol: expected Dobot Magician" in result.message
    assert "Dobot V1.0" in result.message, "names what it found instead"


def test_a_camera_index_that_does_not_exist_stops_the_connected_arm(tmp_path, dobot):
    result = run_dobot(tmp_path, f"arm.port={dobot.path}", "camera.device=57")
    assert result.exit_code == 3 and result.ticks == 0
    assert "57: cannot open camera index 57" in result.message
    assert stopped(dobot), "the arm connected first, so it was told to stop"
    assert logged_result(tmp_path)["exit_code"] == 3


def test_a_stream_that_stops_mid_run_halts_the_run_with_exit_3(tmp_path, dobot, stream):
    server, alive = stream
    results = []
    args = (f"arm.port={dobot.path}", f"camera.device={server.url}", "camera.stall_timeout_s=1.5")
    thread = threading.Thread(target=lambda: results.append(run_dobot(tmp_path, *args)))
    thread.start()
    log = tmp_path / "run" / "run.jsonl"
    deadline = time.monotonic() + 60
    while not (log.exists() and '"kind": "status"' in log.read_text()):
        assert time.monotonic() < deadline and thread.is_alive(), f"the run never ticked: {results}"
        time.sleep(0.05)
    time.sleep(1.0)
    alive.clear()  # the camera goes dark while the tree runs
    thread.join(60)
    (result,) = results
    assert result.exit_code == 3 and result.ticks > 10, result.message
    assert f"{server.url}: " in result.message and "frame" in result.message
    assert stopped(dobot)
    assert logged_result(tmp_path)["exit_code"] == 3


#: Wall seconds the arm that is on the port gets to answer the probe's handshake: a bound
#: against a hang, not a measure of speed (an emulator answers in about 0.1 s when the
#: machine is quiet, and may wait seconds for the CPU when it is not).
ANSWER_S = 20.0
#: Each other protocol waits out its whole handshake, so it gets a short one: not answering
#: is the result whether or not the port's bytes came within it.
REFUSE_S = 0.5


@pytest.mark.parametrize("profile", ["dobot_v1", "dobot_magician", "vicra", "so101", "koch"])
def test_detect_port_probe_names_the_arm_an_emulated_port_answers_as(profile):
    others = [p for p in PROBES if p != profile]
    emu = emulator(profile)
    try:
        # the other protocols first, as a probe of every protocol may, then the arm's own
        refused, tried = probe_port(emu.path, get_plugin_manager(), REFUSE_S, profiles=others)
        answers, tried_own = probe_port(emu.path, get_plugin_manager(), ANSWER_S, [profile])
    finally:
        emu.close()
    assert refused == [], tried
    assert answers == [profile] and tried_own == {profile: "answered"}, tried_own
    assert set(tried) == set(others)


def test_armtree_detect_port_probe_on_the_command_line(dobot):
    import subprocess
    import sys
    from pathlib import Path

    exe = Path(sys.executable).parent / "armtree"
    if not exe.exists():
        pytest.skip("the armtree console script is not installed in this environment")
    # One --timeout serves every protocol here, and the four that are not on the port wait
    # out theirs: 2 s is ten times the emulator's answer on a quiet machine.
    args = [str(exe), "detect-port", "--probe", "--timeout", "2", "--json", dobot.path]
    done = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    (port,) = json.loads(done.stdout)
    assert port["device"] == dobot.path and port["answers"] == ["dobot_v1"], port["tried"]
    assert set(port["tried"]) == set(PROBES) and port["tried"]["dobot_v1"] == "answered"
    # why the Magician's protocol did not fit: the V1's frames, or (when they came late on
    # a busy machine) none at all
    reason = port["tried"]["dobot_magician"]
    assert reason.startswith(("wrong protocol: expected Dobot Magician", "no answer")), reason
