"""``armtree workspace --rig PROFILE [--delta MM] [--plot FILE.png]``."""

import argparse
import subprocess
import sys

import numpy as np
import pytest

from armtree.errors import ConfigError
from armtree.hooks.plugin_manager import make_plugin_manager
from armtree.plugins.planners.plugin import armtree_commands
from armtree.plugins.planners.workspace_command import WorkspaceCommand


def _args(**kw):
    parser = argparse.ArgumentParser()
    WorkspaceCommand().configure(parser)
    argv = []
    for key, value in kw.items():
        argv += [f"--{key}", str(value)]
    return parser.parse_args(argv)


def test_command_is_registered():
    assert isinstance(armtree_commands()["workspace"], WorkspaceCommand)
    assert make_plugin_manager(autoload=False).registry.has("command", "workspace")


def test_run_prints_counts_and_writes_a_png(tmp_path, capsys):
    png = tmp_path / "ws.png"
    assert WorkspaceCommand().run(_args(rig="sim_dobot", delta=8, plot=png)) == 0
    out = capsys.readouterr().out
    assert "inner" in out and "boundary" in out and "place home" in out
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000


def test_profile_with_obstacles_and_vicra(tmp_path, capsys):
    rig = tmp_path / "rig.yaml"
    rig.write_text(
        "profile: rig\n"
        "arm: {type: vicra, port: sim}\n"
        "places: {bin: [300, 100, 50], far: [2000, 0, 50]}\n"
        "obstacles:\n  - box: {center: [0, 380, 50], size: [100, 20, 100]}\n"
    )
    assert WorkspaceCommand().run(_args(rig=rig, delta=40)) == 0
    out = capsys.readouterr().out
    assert "place bin [300.0, 100.0, 50.0] mm: reachable" in out
    assert "place far" in out and "NOT reachable" in out


@pytest.mark.parametrize("delta", [0, -1, float("nan")])
def test_bad_delta_is_a_config_error(delta):
    with pytest.raises(ConfigError, match="--delta"):
        WorkspaceCommand().run(_args(rig="sim_dobot", delta=delta))


def test_cli_subprocess(tmp_path):
    png = tmp_path / "cli.png"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "armtree.cli",
            "workspace",
            "--rig",
            "sim_dobot",
            "--delta",
            "10",
            "--plot",
            str(png),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert png.exists() and "dobot_v1 workspace" in done.stdout
    bad = subprocess.run(
        [sys.executable, "-m", "armtree.cli", "workspace", "--rig", "no_such_rig"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert bad.returncode == 2 and "no_such_rig" in bad.stderr
    assert np.isfinite(float(done.stdout.split(" in ")[1].split(" s")[0]))
