"""The end of a run: plugin lines in the summary, and a final frame that shows how the tree ended."""

import io
import subprocess
import sys
from pathlib import Path

import py_trees
from py_trees.common import Status
from rich.console import Console

from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.loader.tree import Tree
from armtree.runtime.display import LiveView, print_summary, render_tree, summary
from armtree.runtime.run_end import RunResult
from armtree.runtime.runner import run

RUN_TREE = Path(sys.executable).with_name("run-tree")

SIM_TREE = """\
tree: settle
rig: sim_dobot
tick_hz: 20
root:
  sequence:
    name: Root
    children:
      - success: {name: Ready}
"""


def text_of(renderable, width=100):
    console = Console(file=io.StringIO(), width=width, color_system=None)
    console.print(renderable)
    return console.file.getvalue()


def ready_then_wait():
    ready = py_trees.behaviours.Success(name="Ready")
    wait = py_trees.behaviours.Running(name="Wait")
    later = py_trees.behaviours.Success(name="Later")
    root = py_trees.composites.Sequence("Root", memory=True, children=[ready, wait, later])
    return root, ready, wait, later


def test_a_sim_run_tree_prints_the_score_and_its_file(tmp_path):
    (tmp_path / "settle.yaml").write_text(SIM_TREE)
    done = subprocess.run(
        [str(RUN_TREE), "settle.yaml", "--record", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("result: SUCCESS")
    assert "score: ducky on duckybot: no · in bin: none · collisions: 0 · held: none" in lines
    assert "score file: out/score.json" in lines
    assert lines.index("log: out/run.jsonl") < lines.index("score file: out/score.json")
    assert (tmp_path / "out" / "score.json").is_file()


def test_a_run_without_the_sim_has_no_score_line():
    root = py_trees.composites.Sequence(
        "Root", memory=True, children=[py_trees.behaviours.Success(name="Ready")]
    )
    result = run(
        Tree(name="plain", root=root, source=None), record=False, manager=get_plugin_manager()
    )
    assert result.ok and result.details == {}
    text = summary(result)
    assert "score" not in text
    assert text.splitlines()[-1].startswith("ticks: 1")


def test_details_follow_the_summary_lines_in_order_and_are_not_wrapped():
    long = "x" * 150
    result = RunResult(status="FAILURE", ticks=3, seconds=0.1, exit_code=1, message="why not")
    result.details["score"] = "ducky on duckybot: yes"
    result.details["notes"] = long
    assert summary(result).splitlines()[-3:] == [
        "why: why not",
        "score: ducky on duckybot: yes",
        f"notes: {long}",
    ]
    out = io.StringIO()
    print_summary(result, out)
    assert f"notes: {long}\n" in out.getvalue(), "one line even on an 80-column console"


def test_render_tree_shows_the_final_statuses_and_marks_halted_nodes():
    root, ready, wait, later = ready_then_wait()
    root.tick_once()
    root.stop(Status.INVALID)
    assert {n.status for n in root.iterate()} == {Status.INVALID}
    plain = text_of(render_tree(root))
    assert "✓" not in plain and "*" not in plain, "py_trees leaves every node INVALID"
    final = {
        root.id: ("RUNNING", True),
        ready.id: ("SUCCESS", False),
        wait.id: ("RUNNING", True),
        later.id: ("INVALID", False),
    }
    lines = text_of(render_tree(root, statuses=final)).splitlines()
    assert "* Root  [Sequence]  halted" in lines[0]
    assert "✓ Ready  [Success]" in lines[1] and "halted" not in lines[1]
    assert "* Wait  [Running]  halted" in lines[2]
    assert "- Later  [Success]" in lines[3] and "halted" not in lines[3]


def test_render_tree_falls_back_to_the_current_status_for_unknown_nodes():
    root, ready, wait, later = ready_then_wait()
    root.tick_once()
    text = text_of(render_tree(root, statuses={}))
    assert "✓ Ready" in text and "* Wait" in text and "halted" not in text


def test_the_live_views_last_frame_shows_how_a_halted_run_ended():
    root, *_ = ready_then_wait()
    stream = io.StringIO()
    view = LiveView(Console(file=stream, width=100, force_terminal=True, color_system=None))
    result = run(Tree(name="halted", root=root, source=None), record=False, max_ticks=3, view=view)
    assert result.status == "FAILURE"
    assert {n.status for n in root.iterate()} == {Status.INVALID}
    last_frame = stream.getvalue().split("halted  tick 3")[-1]
    assert "* Root  [Sequence]  halted" in last_frame
    assert "✓ Ready  [Success]" in last_frame
    assert "* Wait  [Running]  halted" in last_frame
    assert "- Later  [Success]" in last_frame


def test_a_node_that_is_not_invalid_shows_its_current_status():
    root, ready, wait, later = ready_then_wait()
    root.tick_once()
    text = text_of(render_tree(root, statuses={wait.id: ("INVALID", False)}))
    assert "* Wait" in text and "halted" not in text
