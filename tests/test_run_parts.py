"""The run's collaborators on their own: the tick schedule (pacing), where nodes are
(node index) and what a run's failure report keeps. Whole runs are in test_runtime_*.py."""

from __future__ import annotations

import threading

import py_trees
import pytest
from py_trees.common import Status

from armtree.api.clock import Clock, VirtualClock
from armtree.loader.tree import Tree
from armtree.runtime import pacing
from armtree.runtime.failure_report import EVENTS_KEPT, FailureReport
from armtree.runtime.halting import Halter
from armtree.runtime.interrupts import Interrupts
from armtree.runtime.node_index import NodeIndex
from armtree.runtime.pacing import Pacer


class _Wake:
    """A wake event that records how long it was asked to wait, without waiting."""

    def __init__(self) -> None:
        self.waits: list[float] = []

    def wait(self, timeout: float) -> bool:
        self.waits.append(timeout)
        return False


class _ManualClock(Clock):
    """A wall-like clock (not virtual) whose time the test sets."""

    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t

    def sleep_until(self, t: float) -> None:
        raise AssertionError("a wall clock is waited on through the wake event")


class _Log:
    """Records the events written to it."""

    def __init__(self) -> None:
        self.events: list[tuple[int, float, str, dict]] = []

    def event(self, tick: int, t: float, event: str, **data) -> None:
        self.events.append((tick, t, event, data))


def test_a_virtual_clock_jumps_to_exact_multiples_of_the_period():
    clock = VirtualClock()
    pacer = Pacer(clock, 0.1, threading.Event())
    pacer.start()
    for k in range(1, 31):
        pacer.began(clock.now())
        pacer.advance(k, None)
        # Multiplied, not summed: 30 additions of 0.1 would drift off 3.0.
        assert clock.now() == round(k * 0.1, 9)
    assert pacer.overruns == 0 and pacer.lateness == []


def test_a_wall_clock_waits_for_the_next_tick_and_counts_a_late_one():
    clock, wake = _ManualClock(), _Wake()
    pacer = Pacer(clock, 0.05, wake)  # type: ignore[arg-type]
    pacer.start()
    pacer.began(clock.now())
    clock.t = 0.01  # the tick took 10 ms of its 50
    pacer.advance(1, None)
    assert wake.waits == [pytest.approx(0.04, rel=1e-9, abs=1e-12)]
    clock.t = 0.05 + 0.02  # the next tick started 20 ms late
    pacer.began(clock.now())
    clock.t = 0.2  # and overran its period
    pacer.advance(2, None)
    assert pacer.overruns == 1 and len(wake.waits) == 1, "no wait after an overrun"
    assert pacer.lateness == [pytest.approx(0.0, abs=1e-12), pytest.approx(0.02, abs=1e-12)]
    # The next tick is scheduled from when the late one ended, not bunched to catch up.
    pacer.began(clock.now())
    assert pacer.lateness[-1] == pytest.approx(0.0, abs=1e-12)


def test_speed_pacing_waits_when_ahead_and_counts_falling_behind(monkeypatch):
    wall = [100.0]
    monkeypatch.setattr(pacing.time, "monotonic", lambda: wall[0])
    wake = _Wake()
    pacer = Pacer(VirtualClock(), 0.1, wake)  # type: ignore[arg-type]
    pacer.pace(0.0, 2.0)  # anchors: run time 0 at wall 100
    assert wake.waits == []
    pacer.pace(1.0, 2.0)  # 1 run s at 2x is due 0.5 wall s after the anchor
    assert wake.waits == [pytest.approx(0.5, rel=1e-9)]
    wall[0] = 103.0  # 3 wall s later only 2 run s have passed: behind
    pacer.pace(2.0, 2.0)
    assert pacer.overruns == 1 and len(wake.waits) == 1
    pacer.release()  # after a pause the schedule starts afresh: no catching up
    wall[0] = 200.0
    pacer.pace(2.1, 2.0)
    assert pacer.overruns == 1 and len(wake.waits) == 1


def _tree() -> tuple[Tree, dict[str, py_trees.behaviour.Behaviour]]:
    """Root (selector) -> Branch (sequence: ok, bad), Side (parallel: busy, also)."""
    nodes = {
        "ok": py_trees.behaviours.Success(name="ok"),
        "bad": py_trees.behaviours.Failure(name="bad"),
        "busy": py_trees.behaviours.Running(name="busy"),
        "also": py_trees.behaviours.Running(name="also"),
    }
    branch = py_trees.composites.Sequence(
        "Branch", memory=False, children=[nodes["ok"], nodes["bad"]]
    )
    side = py_trees.composites.Parallel(
        "Side",
        policy=py_trees.common.ParallelPolicy.SuccessOnAll(),
        children=[nodes["busy"], nodes["also"]],
    )
    root = py_trees.composites.Selector("Root", memory=False, children=[branch, side])
    return Tree(name="t", root=root, source=None), nodes


def test_the_node_index_names_nodes_and_finds_the_running_leaves():
    tree, nodes = _tree()
    index = NodeIndex(tree)
    assert index.path_of(nodes["ok"]) == "Root/Branch/ok"
    assert index.where(nodes["ok"]) == "Root/Branch/ok", "no NodeInfo: no file:line"
    assert index.deepest(Status.RUNNING) is None and index.running_leaves() == []
    tree.root.tick_once()  # Branch fails at 'bad', so the selector runs Side
    assert index.running_leaves() == ["Root/Side/busy", "Root/Side/also"]
    assert index.deepest(Status.RUNNING) is nodes["also"], "the last running child at each level"
    assert nodes["bad"].status == Status.FAILURE
    assert index.deepest(Status.FAILURE) is None, "the root is RUNNING, not FAILURE"


def test_the_node_index_finds_where_a_failed_tree_failed():
    bad = py_trees.behaviours.Failure(name="bad")
    inner = py_trees.composites.Sequence(
        "Inner", memory=False, children=[py_trees.behaviours.Success(name="ok"), bad]
    )
    root = py_trees.composites.Sequence("Job", memory=False, children=[inner])
    index = NodeIndex(Tree(name="job", root=root, source=None))
    root.tick_once()
    assert index.deepest(Status.FAILURE) is bad
    other = py_trees.behaviours.Success(name="other")
    index.use(Tree(name="other", root=other, source=None))
    assert index.deepest(Status.FAILURE) is None and index.path_of(other) == "other"


def _report() -> tuple[FailureReport, Interrupts, _Log]:
    tree, _ = _tree()
    interrupts, log = Interrupts(), _Log()
    index = NodeIndex(tree)

    class _View:
        def __init__(self) -> None:
            self.messages: list[str] = []

        def message(self, text: str) -> None:
            self.messages.append(text)

    report = FailureReport(
        clock=VirtualClock(),
        interrupts=interrupts,
        index=index,
        halter=Halter(None),
        view=_View(),
        log=log,  # type: ignore[arg-type]
    )
    return report, interrupts, log


def test_the_first_fail_reason_wins_and_wakes_the_run():
    report, interrupts, log = _report()
    report.fail("collision with the table")
    report.fail("a later collision")
    assert interrupts.wake.is_set()
    end = report.component_failed(7)
    assert (end.status, end.message) == ("FAILURE", "collision with the table")
    assert log.events == [(7, 0.0, "fail", {"reason": "collision with the table", "running": []})]


def test_reported_events_are_all_logged_and_the_first_ones_kept_for_the_summary():
    report, _, log = _report()
    for i in range(EVENTS_KEPT + 5):
        report.event(i, "drop", f"dropped {i}", body="duck")
    report.event(999, "frame")  # no message: logged only
    assert len(log.events) == EVENTS_KEPT + 6
    assert len(report.events) == EVENTS_KEPT
    assert report.events[0] == {"tick": 0, "t": 0.0, "event": "drop", "message": "dropped 0"}
    assert report.view.messages[0] == "t=0.00s dropped 0"
