"""The tick loop: statuses tick by tick, ends (success, failure, timeout, max ticks), clocks."""

import py_trees
import pytest
from py_trees.common import Status

import armtree
from armtree.api.clock import VirtualClock, WallClock
from armtree.api.rig import Rig
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.tree import Tree
from armtree.runtime.runlog import read_log
from armtree.runtime.runner import Run, run

S, F, R, INV = Status.SUCCESS, Status.FAILURE, Status.RUNNING, Status.INVALID


class Recorder:
    """A lifecycle plugin that snapshots every node's status after each tick."""

    def __init__(self, nodes):
        self.nodes = nodes
        self.snapshots = []
        self.calls = []

    @armtree.hookimpl
    def armtree_run_started(self, run):
        self.calls.append(("started", run.tick_count))

    @armtree.hookimpl
    def armtree_tick(self, run):
        self.snapshots.append(tuple(n.status for n in self.nodes))

    @armtree.hookimpl
    def armtree_run_finished(self, run, result):
        self.calls.append(("finished", result.status, result.ticks))


def run_recorded(root, nodes, **kwargs):
    manager = PluginManager(autoload=False)
    recorder = Recorder(nodes)
    manager.register(recorder, "recorder")
    tree = Tree(name="t", root=root, source=None)
    result = run(tree, manager=manager, record=False, **kwargs)
    return result, recorder


def counter(name, ticks, status=S):
    """RUNNING for ``ticks`` ticks, then ``status``."""
    return py_trees.behaviours.TickCounter(name=name, duration=ticks, completion_status=status)


def test_sequence_statuses_tick_by_tick():
    a, b = counter("a", 1), counter("b", 2)
    seq = py_trees.composites.Sequence("seq", memory=True, children=[a, b])
    result, rec = run_recorded(seq, [seq, a, b])
    assert rec.snapshots == [(R, R, INV), (R, S, R), (R, S, R), (S, S, S)]
    assert (result.status, result.ticks, result.exit_code) == ("SUCCESS", 4, 0)
    assert rec.calls == [("started", 0), ("finished", "SUCCESS", 4)]


def test_selector_statuses_tick_by_tick_and_failure_is_reported():
    a, b = counter("a", 1, F), counter("b", 1, F)
    sel = py_trees.composites.Selector("sel", memory=True, children=[a, b])
    result, rec = run_recorded(sel, [sel, a, b])
    assert rec.snapshots == [
        (R, R, INV),
        (R, F, R),
        (F, INV, F),
    ]  # py_trees resets the first child once all failed
    assert result.status == "FAILURE" and result.exit_code == 1
    assert result.failed_node == "sel/b"
    assert "sel/b" in result.message


def test_parallel_success_on_all_statuses_tick_by_tick():
    a, b = counter("a", 1), counter("b", 3)
    par = py_trees.composites.Parallel(
        "par", policy=py_trees.common.ParallelPolicy.SuccessOnAll(), children=[a, b]
    )
    result, rec = run_recorded(par, [par, a, b])
    assert rec.snapshots == [(R, R, R), (R, S, R), (R, S, R), (S, S, S)]
    assert result.status == "SUCCESS" and result.ticks == 4


def test_parallel_success_on_one_halts_the_other_child():
    a, b = counter("a", 1), py_trees.behaviours.Running(name="b")
    par = py_trees.composites.Parallel(
        "par", policy=py_trees.common.ParallelPolicy.SuccessOnOne(), children=[a, b]
    )
    result, rec = run_recorded(par, [par, a, b])
    assert rec.snapshots[-1] == (S, S, INV)
    assert result.status == "SUCCESS"


class FailUntil(py_trees.behaviour.Behaviour):
    """FAILURE for the first ``n - 1`` ticks, SUCCESS from the ``n``-th on."""

    def __init__(self, name, n):
        super().__init__(name)
        self.n, self.calls = n, 0

    def update(self):
        self.calls += 1
        return S if self.calls >= self.n else F


def test_reactive_selector_preempts_a_running_lower_priority_branch():
    high = py_trees.composites.Sequence("high", memory=False, children=[FailUntil("ready", 3)])
    low = py_trees.behaviours.Running(name="low")
    sel = py_trees.composites.Selector("sel", memory=False, children=[high, low])
    result, rec = run_recorded(sel, [sel, high, low], max_ticks=5)
    # Ticks 1-2: the high branch fails, the low one runs; tick 3: the high branch
    # succeeds and the running low branch is halted.
    assert rec.snapshots == [(R, F, R), (R, F, R), (S, S, INV)]
    assert result.status == "SUCCESS" and result.ticks == 3


def test_timeout_on_the_virtual_clock_is_exact_and_fast():
    tree = Tree(name="forever", root=py_trees.behaviours.Running(name="spin"), source=None)
    r = Run(tree, record=False, timeout=2.0)
    result = r.execute()
    assert isinstance(r.clock, VirtualClock)
    assert result.status == "FAILURE" and result.exit_code == 1
    assert "timeout" in result.message
    assert result.ticks == 40 and result.seconds == pytest.approx(2.0)
    assert result.running == ["spin"]
    assert result.overruns == 0


def test_max_ticks_ends_as_failure_and_halts_running_nodes():
    spin = py_trees.behaviours.Running(name="spin")
    root = py_trees.composites.Sequence("root", memory=True, children=[spin])
    result = run(Tree(name="t", root=root, source=None), record=False, max_ticks=7)
    assert result.status == "FAILURE" and result.ticks == 7
    assert "max ticks" in result.message
    assert spin.status == INV and root.status == INV


def test_tick_hz_sets_the_virtual_time_step():
    tree = Tree(name="t", root=counter("c", 9), source=None, tick_hz=5)
    result = run(tree, record=False)
    assert result.ticks == 10 and result.seconds == pytest.approx(9 * 0.2)


def test_same_seed_same_log(tmp_path):
    def once(d):
        a = counter("a", 3)
        b = py_trees.behaviours.Periodic(name="b", n=2)
        par = py_trees.composites.Parallel(
            "par", policy=py_trees.common.ParallelPolicy.SuccessOnOne(), children=[a, b]
        )
        result = run(Tree(name="t", root=par, source=None), record=tmp_path / d, seed=4)
        return [rec for rec in read_log(result.log_path) if rec["kind"] in ("status", "result")]

    first, second = once("1"), once("2")
    for rec in first + second:
        rec.pop("wall_seconds", None)
    assert first == second and len(first) > 5


def test_realtime_uses_the_wall_clock_and_counts_no_overruns_on_an_idle_tree():
    tree = Tree(name="t", root=counter("c", 2), source=None, tick_hz=200)
    r = Run(tree, record=False, realtime=True)
    result = r.execute()
    assert isinstance(r.clock, WallClock)
    assert result.status == "SUCCESS" and result.ticks == 3
    assert result.seconds >= 2 / 200


def test_a_wall_clock_run_counts_overruns():
    class Slow(py_trees.behaviour.Behaviour):
        def __init__(self):
            super().__init__("slow")
            self.n = 0

        def update(self):
            self.n += 1
            # Busy-wait past the 5 ms period on the wall clock without sleeping.
            import time

            end = time.monotonic() + 0.008
            while time.monotonic() < end:
                pass
            return S if self.n >= 3 else R

    rig = Rig(profile=None, clock=WallClock())
    result = run(Tree(name="t", root=Slow(), source=None, tick_hz=200), rig=rig, record=False)
    assert result.overruns >= 2


def test_run_executes_once():
    r = Run(Tree(name="t", root=py_trees.behaviours.Success("s"), source=None), record=False)
    r.execute()
    with pytest.raises(RuntimeError):
        r.execute()


def test_blackboard_is_cleared_and_initialised_per_run():
    py_trees.blackboard.Blackboard.set("/stale", 1)
    check = py_trees.behaviours.CheckBlackboardVariableValue(
        name="check",
        check=py_trees.common.ComparisonExpression("speed", 3, lambda a, b: a == b),
    )
    tree = Tree(name="t", root=check, source=None, blackboard={"speed": 3})
    assert run(tree, record=False).status == "SUCCESS"
    assert not py_trees.blackboard.Blackboard.exists("/stale")
    tree2 = Tree(name="t", root=check, source=None, blackboard={"speed": 4})
    assert run(tree2, record=False).status == "FAILURE"
