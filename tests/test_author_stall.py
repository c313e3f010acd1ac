"""A run that makes no progress is reported as a stall and ends at run-tree's default
timeout on the simulation (issue 29)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from plugin_author import run_tree, write

from armtree.config.profile_sections import DEFAULT_STALL_S
from armtree.runtime.run_start import DEFAULT_SIM_TIMEOUT_S
from armtree.runtime.stall_watch import MOTION_TOL, StallWatch

SKILLS = """
    import py_trees
    from py_trees.common import Status

    import armtree


    class Waiter(py_trees.behaviour.Behaviour):
        \"\"\"Waits for something that never comes, saying nothing new.\"\"\"

        def initialise(self):
            self.feedback_message = "waiting for the go"

        def update(self):
            return Status.RUNNING


    @armtree.hookimpl
    def armtree_behaviours():
        return {"waiter": Waiter}
"""

TREE = """
    plugins: [my_skills.py]
    root:
      sequence:
        name: Root
        children:
          - success: {}
          - waiter: {}
"""


def test_a_tree_that_makes_no_progress_is_reported_as_a_stall_and_ends_at_the_default_timeout(
    tmp_path,
):
    folder = write(tmp_path, {"my_skills.py": SKILLS, "t.yaml": TREE})
    done = run_tree(folder, "t.yaml", "--record", "rec", timeout=120)
    assert done.returncode == 1, done.stdout + done.stderr
    # The live (here plain) view says so when it happens.
    stall_line = (
        f"t={DEFAULT_STALL_S:.2f}s stall: no progress for {DEFAULT_STALL_S:g} s (no status "
        "change, motion, blackboard write or feedback change) while Root/waiter ran"
    )
    assert stall_line in done.stdout
    assert (
        f"timeout: {DEFAULT_SIM_TIMEOUT_S:g} s on the run clock reached; no progress since "
        "t=0.00 s (a stall)" in done.stdout
    )
    records = [json.loads(line) for line in (folder / "rec" / "run.jsonl").read_text().splitlines()]
    (stall,) = [r for r in records if r.get("event") == "stall"]
    assert stall["t"] == pytest.approx(DEFAULT_STALL_S) and stall["running"] == ["Root/waiter"]
    assert records[-1]["seconds"] == pytest.approx(DEFAULT_SIM_TIMEOUT_S)
    # With no view at all, the stall is still said, once, on stderr.
    quiet = run_tree(folder, "t.yaml", "--quiet", timeout=120)
    assert quiet.returncode == 1
    assert [line for line in quiet.stderr.splitlines() if "stall" in line] == [
        f"warning: {stall_line}"
    ]


def test_timeout_inf_lifts_the_default_and_max_ticks_still_ends_the_run(tmp_path):
    folder = write(tmp_path, {"my_skills.py": SKILLS, "t.yaml": TREE})
    ticks = int(DEFAULT_SIM_TIMEOUT_S * 20) + 100
    done = run_tree(folder, "t.yaml", "--quiet", "--timeout", "inf", "--max-ticks", str(ticks))
    assert done.returncode == 1
    assert f"max ticks: {ticks} ticks reached" in done.stdout


@pytest.mark.parametrize("value", ["0", "-3", "nan"])
def test_a_timeout_that_is_not_positive_is_refused(tmp_path, value):
    folder = write(tmp_path, {"my_skills.py": SKILLS, "t.yaml": TREE})
    done = run_tree(folder, "t.yaml", "--quiet", f"--timeout={value}")
    assert done.returncode == 2
    assert "give a positive number of seconds (inf: no limit)" in done.stderr


class _Node:
    def __init__(self) -> None:
        self.feedback_message = ""


class _Arm:
    def __init__(self) -> None:
        self.q = np.zeros(3)

    def joints(self) -> np.ndarray:
        return self.q.copy()


def _quiet_for(watch: StallWatch, statuses: tuple, start: float, seconds: float) -> bool:
    """Observe quiet ticks at 20 Hz from ``start`` for ``seconds``; True if a stall began."""
    began = False
    for i in range(1, int(seconds * 20) + 1):
        began |= watch.observe(start + i / 20, statuses, False)
    return began


def test_the_stall_watch_counts_each_kind_of_progress_and_reports_a_stall_once():
    node, arm = _Node(), _Arm()
    watch = StallWatch(limit_s=2.0)
    watch.start(0.0, [node], arm)
    statuses = ("RUNNING",)
    assert watch.observe(0.05, statuses, False) is False  # the first statuses seen
    assert _quiet_for(watch, statuses, 0.05, 1.9) is False
    # A status change, a blackboard write, a feedback change, a motion: each restarts it.
    assert watch.observe(2.0, ("SUCCESS",), False) is False
    assert watch.quiet_since == pytest.approx(2.0)
    assert watch.observe(2.05, ("SUCCESS",), True) is False
    assert watch.quiet_since == pytest.approx(2.05)
    assert watch.observe(2.1, ("SUCCESS",), False) is False  # what was said, where the arm was
    node.feedback_message = "3 s left"
    assert watch.observe(2.15, ("SUCCESS",), False) is False
    assert watch.quiet_since == pytest.approx(2.15)
    assert watch.observe(2.2, ("SUCCESS",), False) is False
    arm.q[1] += 3 * MOTION_TOL
    assert watch.observe(2.25, ("SUCCESS",), False) is False
    assert watch.quiet_since == pytest.approx(2.25)
    # A reading's jitter is not motion: the stall begins 2 s after the last progress.
    arm.q[1] += 0.5 * MOTION_TOL
    assert _quiet_for(watch, ("SUCCESS",), 2.25, 1.95) is False
    assert watch.observe(4.25, ("SUCCESS",), False) is True and watch.stalled
    assert _quiet_for(watch, ("SUCCESS",), 4.25, 5.0) is False  # reported once
    assert watch.longest == pytest.approx(7.0)
    node.feedback_message = "moving on"
    assert watch.observe(9.3, ("SUCCESS",), False) is False and not watch.stalled
