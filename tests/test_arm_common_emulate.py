"""``armtree emulate ARM``: a firmware emulator on its own, for any serial client."""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import threading

import pytest
import serial

from armtree.errors import ConfigError
from armtree.plugins.arms.dobot_v1 import codec
from armtree.plugins.arms.plugin import EmulateCommand


def _args(*argv):
    parser = argparse.ArgumentParser()
    command = EmulateCommand()
    command.configure(parser)
    return command, parser.parse_args(list(argv))


def _read_status(path):
    with serial.Serial(path, 9600, timeout=2.0) as port:
        parser = codec.frame_parser()
        for _ in range(50):
            frames = parser.feed(port.read(42))
            if frames:
                return codec.Status.decode(frames[0])
    raise AssertionError("no status frame")


def test_emulate_runs_in_process_until_stopped(capsys):
    command, args = _args("dobot_v1")
    result = {}
    thread = threading.Thread(target=lambda: result.setdefault("code", command.run(args)))
    thread.start()
    try:
        for _ in range(200):
            out = capsys.readouterr().out
            if out:
                break
            threading.Event().wait(0.01)
        path = out.splitlines()[0]
        assert path.startswith("/dev/")
        status = _read_status(path)
        assert status.joints == pytest.approx((0.0, 10.0, 50.0), abs=1e-4)
    finally:
        command.stop.set()
        thread.join(5)
    assert result["code"] == 0


def test_emulate_unknown_arm_is_a_usage_error():
    command, args = _args("no_such_arm")
    with pytest.raises(ConfigError, match="unknown arm type"):
        command.run(args)


def test_emulate_profile_of_another_arm_is_refused(tmp_path):
    profile = tmp_path / "p.yaml"
    profile.write_text("profile: p\narm: {type: dobot_v1, port: sim}\n")
    command, args = _args("dobot_magician", "--profile", str(profile))
    with pytest.raises(ConfigError, match="not 'dobot_magician'"):
        command.run(args)


@pytest.mark.skipif(
    shutil.which("armtree", path=os.path.dirname(sys.executable)) is None,
    reason="the armtree console script is not installed in this environment",
)
def test_armtree_emulate_subprocess_prints_the_path_then_serves():
    exe = os.path.join(os.path.dirname(sys.executable), "armtree")
    proc = subprocess.Popen(
        [exe, "emulate", "dobot_v1"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        path = proc.stdout.readline().strip()
        assert path.startswith("/dev/")
        assert _read_status(path).joints == pytest.approx((0.0, 10.0, 50.0), abs=1e-4)
    finally:
        proc.send_signal(signal.SIGINT)
        code = proc.wait(10)
    assert code == 130, "an interrupted command exits 130"


def test_emulate_set_chooses_the_firmware_and_checks_the_option():
    command, args = _args("dobot_v1", "--set", "firmware=open-dobot", "--set", "board=ramps")
    from armtree.hooks.plugin_manager import get_plugin_manager

    config = command._config(args, get_plugin_manager())
    assert config["firmware"] == "open-dobot" and config["board"] == "ramps"
    command, args = _args("dobot_v1", "--set", "firmware=marlin")
    with pytest.raises(ConfigError, match="firmware"):
        command._config(args, get_plugin_manager())
    command, args = _args("dobot_v1", "--set", "colour=red")
    with pytest.raises(ConfigError, match="no option 'colour'"):
        command._config(args, get_plugin_manager())
