"""A behaviour's feedback_message reaches the user: live view, plain lines, run log, summary."""

from __future__ import annotations

import io
import re
import textwrap
from pathlib import Path

import pytest
from rich.console import Console

import armtree
from armtree.cli.commandline import run_tree_main
from armtree.runtime.display import LiveView
from armtree.runtime.runlog import read_log

ROOT = Path(__file__).resolve().parents[1]


def readme_beep() -> str:
    """The README's "Writing a plugin" example, verbatim."""
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    (beep,) = [b for b in blocks if "class Beep" in b]
    return beep


@pytest.fixture
def beep_tree(tmp_path: Path) -> Path:
    (tmp_path / "my_skills.py").write_text(readme_beep())
    tree = tmp_path / "hello.yaml"
    tree.write_text(
        textwrap.dedent(
            """
            plugins: [my_skills.py]
            root:
              sequence:
                name: Greet
                children:
                  - beep: {name: Say it, text: hello from the README's Beep}
                  - success: {}
            """
        )
    )
    return tree


def test_the_readme_beep_text_shows_in_the_plain_view_and_the_run_log(beep_tree, tmp_path, capsys):
    code = run_tree_main([str(beep_tree), "--record", str(tmp_path / "run")])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "Greet/Say it: INVALID -> SUCCESS  (hello from the README's Beep)" in out
    records = read_log(tmp_path / "run" / "run.jsonl")
    feedback = [r for r in records if r["kind"] == "feedback" and r["node"] == "Greet/Say it"]
    assert feedback == [
        {
            "kind": "feedback",
            "tick": 1,
            "t": 0.0,
            "node": "Greet/Say it",
            "status": "SUCCESS",
            "message": "hello from the README's Beep",
        }
    ]


def test_the_live_view_shows_feedback_messages(beep_tree):
    stream = io.StringIO()
    console = Console(file=stream, force_terminal=True, width=140, color_system=None)
    tree = armtree.load_tree(beep_tree)
    result = armtree.run(tree, record=False, view=LiveView(console), stop_key=False)
    assert result.ok
    last_frame = stream.getvalue().rsplit("Greet", 2)[-2:]
    assert "Say it  [Beep]  hello from the README's Beep" in "".join(last_frame)


COUNTDOWN = '''
import armtree
from py_trees.common import Status


class Countdown(armtree.Behaviour):
    """Count ticks down, saying how many are left; fail at the end."""

    PARAMS = (armtree.Param("ticks", "int", 60),)

    def initialise(self):
        self.left = self.param("ticks")

    def update(self):
        self.left -= 1
        if self.left <= 0:
            self.feedback_message = "out of ticks: the lift never came"
            return Status.FAILURE
        self.feedback_message = f"{self.left} ticks left"
        return Status.RUNNING


@armtree.hookimpl
def armtree_behaviours():
    return {"countdown": Countdown}
'''


def test_running_feedback_is_logged_once_a_second_and_the_failure_reason_always(tmp_path, capsys):
    (tmp_path / "countdown.py").write_text(COUNTDOWN)
    tree = tmp_path / "wait.yaml"
    tree.write_text("plugins: [countdown.py]\ntick_hz: 20\nroot:\n  countdown: {name: Lift}\n")
    code = run_tree_main([str(tree), "--record", str(tmp_path / "run"), "--quiet"])
    out = capsys.readouterr().out
    assert code == 1
    assert "why: the tree failed at Lift" in out and "out of ticks: the lift never came" in out
    records = [r for r in read_log(tmp_path / "run" / "run.jsonl") if r["kind"] == "feedback"]
    # 59 RUNNING ticks (2.95 s) changed the message every tick: logged at t = 0, 1 and 2 s only.
    assert [(r["t"], r["message"]) for r in records] == [
        (0.0, "59 ticks left"),
        (1.0, "39 ticks left"),
        (2.0, "19 ticks left"),
        (2.95, "out of ticks: the lift never came"),
    ]
    assert records[-1]["status"] == "FAILURE"


HOLDS = '''
import armtree
from py_trees.common import Status


class Holds(armtree.Behaviour):
    """Succeed at once, saying why."""

    def update(self):
        self.feedback_message = "the tool reports gripping"
        return Status.SUCCESS


@armtree.hookimpl
def armtree_behaviours():
    return {"holds": Holds}
'''


def test_an_inverted_success_names_the_childs_own_reason(tmp_path, capsys):
    (tmp_path / "holds.py").write_text(HOLDS)
    tree = tmp_path / "empty.yaml"
    tree.write_text(
        "plugins: [holds.py]\nroot:\n  inverter:\n    name: Hands empty\n"
        "    child: {holds: {name: Still holding?}}\n"
    )
    code = run_tree_main([str(tree), "--quiet", "--record", str(tmp_path / "run")])
    out = capsys.readouterr().out
    assert code == 1
    assert "failed at Hands empty" in out
    assert "(Still holding?: the tool reports gripping)" in out
