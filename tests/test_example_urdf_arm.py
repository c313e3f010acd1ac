"""examples/my_urdf_arm: the "Another URDF arm" of docs/bus_servo_arms.md, as a user runs it.

The page shows the example's own ``arm:`` section; ``armtree check`` passes on the
example (exit 0) and ``run-tree`` moves the arm through its places on the bus
emulator; a home that does not hold the tool along ``tool_axis`` is exit 2 at its
line and column.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "my_urdf_arm"
BIN = Path(sys.executable).parent
console = pytest.mark.skipif(
    not (BIN / "armtree").exists(), reason="the armtree console scripts are not installed"
)


@pytest.fixture
def example(tmp_path) -> Path:
    """A copy of the example folder (a run writes its log beside the tree)."""
    return Path(shutil.copytree(EXAMPLE, tmp_path / "my_urdf_arm"))


def cli(folder: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(BIN / args[0]), *args[1:]], cwd=folder, capture_output=True, text=True, timeout=120
    )


def test_the_page_shows_the_examples_arm_section():
    page = (ROOT / "docs" / "bus_servo_arms.md").read_text()
    section = page[page.index("### Another URDF arm") :]
    shown = yaml.safe_load(re.search(r"```yaml\n(.*?)```", section, re.S).group(1))
    profile = yaml.safe_load((EXAMPLE / "my_arm.yaml").read_text())
    assert shown["arm"] == profile["arm"]


@console
def test_armtree_check_passes_on_the_example(example):
    done = cli(example, "armtree", "check", "reach.yaml", "--rig", "my_arm.yaml")
    assert done.returncode == 0, done.stdout + done.stderr
    assert "ok: reach: 5 nodes at 20 Hz on my_arm" in done.stdout


@console
def test_the_example_reaches_its_places_on_the_bus_emulator(example):
    done = cli(example, "run-tree", "reach.yaml", "--quiet", "--record", "run")
    assert done.returncode == 0, done.stdout + done.stderr
    assert "result: SUCCESS" in done.stdout
    assert (example / "run" / "run.jsonl").exists()


@console
def test_a_home_off_the_tool_axis_is_exit_2_at_its_line(example):
    profile = example / "my_arm.yaml"
    text = profile.read_text()
    assert "home: [0, 60, 90, 60]" in text
    profile.write_text(text.replace("home: [0, 60, 90, 60]", "home: [0, 60, 60, 60]"))
    line = next(n for n, s in enumerate(text.splitlines(), 1) if s.startswith("  home:"))
    done = cli(example, "armtree", "check", "reach.yaml", "--rig", "my_arm.yaml")
    assert done.returncode == 2, done.stdout + done.stderr
    assert f"my_arm.yaml:{line}:9: arm.home: [0.0, 60.0, 60.0, 60.0] holds the tool 30.0 deg" in (
        done.stderr
    )
    assert "Traceback" not in done.stderr
