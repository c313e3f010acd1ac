"""Stopping safely: exclusive resources, exceptions, component interrupts, multi-tick halts, hooks."""

import threading

import py_trees
import pytest
from py_trees.common import Status

import armtree
from armtree.api.clock import VirtualClock
from armtree.api.rig import Rig
from armtree.errors import HardwareFault, Mark
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.tree import NodeInfo, Tree
from armtree.runtime.resources import Resources
from armtree.runtime.runlog import read_log
from armtree.runtime.runner import run


class FakeArm:
    """Records every command in order; what a real driver would send as bytes."""

    def __init__(self):
        self.commands = []

    def stop(self):
        self.commands.append(("arm.stop",))


class Move(armtree.Behaviour):
    """Commands the arm while RUNNING; stops its own motion when halted."""

    RESOURCES = ("arm",)

    def __init__(self, name, ticks=1000, **params):
        super().__init__(name, **params)
        self.ticks = ticks
        self.count = 0

    def initialise(self):
        self.count = 0
        self.rig.arm.commands.append(("start", self.name))

    def update(self):
        self.count += 1
        return Status.SUCCESS if self.count >= self.ticks else Status.RUNNING

    def terminate(self, new_status):
        if new_status == Status.INVALID:
            self.rig.arm.commands.append(("halt", self.name))


class FailUntil(py_trees.behaviour.Behaviour):
    def __init__(self, name, n):
        super().__init__(name)
        self.n, self.calls = n, 0

    def update(self):
        self.calls += 1
        return Status.SUCCESS if self.calls >= self.n else Status.FAILURE


def fake_rig():
    return Rig(profile=None, clock=VirtualClock(), arm=FakeArm())


def preempting_tree():
    high = py_trees.composites.Sequence(
        "Emergency", memory=False, children=[FailUntil("obstacle seen", 3), Move("retreat", 2)]
    )
    low = Move("pick", 1000)
    return py_trees.composites.Selector("Root", memory=False, children=[high, low])


def test_preemption_halts_the_old_owner_before_the_new_one_commands_the_arm(tmp_path):
    rig = fake_rig()
    result = run(Tree(name="t", root=preempting_tree(), source=None), rig=rig, record=tmp_path)
    assert result.status == "SUCCESS"
    # py_trees alone would give start pick, start retreat, halt pick.
    assert rig.arm.commands == [("start", "pick"), ("halt", "pick"), ("start", "retreat")]
    events = [r for r in read_log(result.log_path) if r.get("event") == "preempt"]
    assert events == [
        {
            "kind": "event",
            "tick": 3,
            "t": pytest.approx(0.1),
            "event": "preempt",
            "resource": "arm",
            "halted": "Root/pick",
            "owner": "Root/Emergency/retreat",
        }
    ]


def test_resources_claim_halts_each_previous_owner_once():
    halted = []
    table = Resources(halt=halted.append)
    a, b = Move("a"), Move("b")
    a.status = Status.RUNNING
    assert table.claim(a, ["arm", "tool"]) == []
    made = table.claim(b, ["arm", "tool"])
    assert halted == [a]
    assert [p.resource for p in made] == ["arm", "tool"]
    assert table.owner("arm") is None  # b is not RUNNING yet
    b.status = Status.RUNNING
    assert table.owner("tool") is b
    assert table.claim(b, ["arm"]) == []


def test_resources_ignore_a_finished_previous_owner():
    halted = []
    table = Resources(halt=halted.append)
    a = Move("a")
    a.status = Status.RUNNING
    table.claim(a, ["head"])
    a.status = Status.SUCCESS
    table.claim(Move("b"), ["head"])
    assert halted == []


class Boom(armtree.Behaviour):
    def __init__(self, name, at=2):
        super().__init__(name)
        self.at, self.n = at, 0

    def update(self):
        self.n += 1
        if self.n >= self.at:
            raise ZeroDivisionError("the gripper maths went wrong")
        return Status.RUNNING


def test_exception_in_a_behaviour_fails_the_run_with_path_and_yaml_line(tmp_path):
    rig = fake_rig()
    boom = Boom("compute grasp")
    mover = Move("hold", 1000)
    root = py_trees.composites.Parallel(
        "Pick", policy=py_trees.common.ParallelPolicy.SuccessOnAll(), children=[mover, boom]
    )
    nodes = {
        root.id: NodeInfo("Pick", "parallel", Mark("pick.yaml", 3, 3)),
        boom.id: NodeInfo("Pick/compute grasp", "boom", Mark("pick.yaml", 9, 9)),
    }
    tree = Tree(name="pick", root=root, source=None, nodes=nodes)
    result = run(tree, rig=rig, record=tmp_path)
    assert result.status == "FAILURE" and result.exit_code == 1
    assert result.failed_node == "Pick/compute grasp"
    assert "ZeroDivisionError" in result.message
    assert "Pick/compute grasp (pick.yaml:9)" in result.message
    assert "the gripper maths went wrong" in result.message
    assert "Traceback" in result.traceback and "Traceback" not in result.message
    # The whole tree was halted: the running mover stopped its motion, the arm was told to stop.
    assert rig.arm.commands == [("start", "hold"), ("halt", "hold"), ("arm.stop",)]
    assert mover.status == Status.INVALID and root.status == Status.INVALID
    log = read_log(result.log_path)
    assert any(r.get("event") == "exception" and r["node"] == "Pick/compute grasp" for r in log)
    assert log[-1]["kind"] == "result" and log[-1]["status"] == "FAILURE"


def test_hardware_fault_raised_by_a_behaviour_exits_3():
    class Lost(armtree.Behaviour):
        def update(self):
            raise HardwareFault("no status frame for 1 s", "/dev/pts/9")

    result = run(Tree(name="t", root=Lost("move"), source=None), record=False)
    assert result.status == "FAILURE" and result.exit_code == 3
    assert "/dev/pts/9" in result.message


def test_exception_in_setup_is_reported_with_the_node():
    class BadSetup(armtree.Behaviour):
        def setup(self, **kwargs):
            raise KeyError("camera")

        def update(self):
            return Status.SUCCESS

    result = run(Tree(name="t", root=BadSetup("look"), source=None), record=False)
    assert result.status == "FAILURE" and result.ticks == 0
    assert "setup of look" in result.message


class Beacon(armtree.Behaviour):
    """Raises a component interrupt from another thread at its ``at``-th tick."""

    def __init__(self, name, at, fault=None):
        super().__init__(name)
        self.at, self.n, self.fault = at, 0, fault
        self.terminated = []

    def update(self):
        self.n += 1
        if self.n == self.at:
            t = threading.Thread(target=self.runtime.interrupt, args=("e-stop pressed", self.fault))
            t.start()
            t.join()
        return Status.RUNNING

    def terminate(self, new_status):
        self.terminated.append(new_status)


def test_component_interrupt_halts_within_one_tick(tmp_path):
    rig = fake_rig()
    beacon = Beacon("watch", at=3)
    result = run(Tree(name="t", root=beacon, source=None), rig=rig, record=tmp_path)
    assert result.status == "INTERRUPTED" and result.exit_code == 130
    assert result.ticks == 3
    assert beacon.terminated == [Status.INVALID]
    assert rig.arm.commands == [("arm.stop",)]
    assert "e-stop pressed" in result.message and "watch" in result.message
    log = read_log(result.log_path)
    assert any(r.get("event") == "interrupt" and r["running"] == ["watch"] for r in log)


def test_component_hardware_fault_exits_3():
    beacon = Beacon("watch", at=2, fault=HardwareFault("link lost", "/dev/ttyUSB0"))
    result = run(Tree(name="t", root=beacon, source=None), rig=fake_rig(), record=False)
    assert result.status == "INTERRUPTED" and result.exit_code == 3
    assert "link lost" in result.message


class Decelerating(armtree.Behaviour):
    """Needs ``settle`` clock steps after a halt to be safe (or forever with None)."""

    def __init__(self, name, settle):
        super().__init__(name)
        self.settle = settle
        self.halted_at = None

    def update(self):
        return Status.RUNNING

    def terminate(self, new_status):
        if new_status == Status.INVALID:
            self.halted_at = self.now()

    def halting(self):
        if self.halted_at is None:
            return False
        if self.settle is None:
            return True
        return self.now() < self.halted_at + self.settle * 0.05 - 1e-9


def test_a_halting_behaviour_gets_clock_steps_until_safe():
    rig = fake_rig()
    steps = []
    rig.steppers.append(steps.append)
    node = Decelerating("slow down", settle=4)
    result = run(Tree(name="t", root=node, source=None), rig=rig, record=False, max_ticks=2)
    assert result.status == "FAILURE"
    assert len(steps) == 2 + 4
    assert steps[-1] == pytest.approx(node.halted_at + 0.2)
    assert "not safe" not in result.message


def test_the_stop_timeout_bounds_a_halt_that_never_settles():
    rig = fake_rig()
    node = Decelerating("stuck", settle=None)
    result = run(
        Tree(name="t", root=node, source=None),
        rig=rig,
        record=False,
        max_ticks=1,
        stop_timeout=0.5,
    )
    assert rig.clock.now() - node.halted_at == pytest.approx(0.5)
    assert "not safe after the 0.5 s stop timeout: stuck" in result.message


class Broken:
    def __init__(self):
        self.finished = None

    @armtree.hookimpl
    def armtree_tick(self, run):
        raise RuntimeError("monitor bug")

    @armtree.hookimpl
    def armtree_run_finished(self, run, result):
        self.finished = result.status


class Watcher:
    def __init__(self):
        self.reasons = []

    @armtree.hookimpl
    def armtree_interrupt(self, run, reason):
        self.reasons.append((reason, run.tick_count))


def test_a_raising_hook_is_reported_and_the_run_goes_on(tmp_path, capsys):
    manager = PluginManager(autoload=False)
    broken, watcher = Broken(), Watcher()
    manager.register(broken, "broken")
    manager.register(watcher, "watcher")
    counter = py_trees.behaviours.TickCounter(
        name="c", duration=3, completion_status=Status.SUCCESS
    )
    tree = Tree(name="t", root=counter, source=None)
    result = run(tree, manager=manager, record=tmp_path)
    assert result.status == "SUCCESS" and result.ticks == 4
    assert broken.finished == "SUCCESS"
    errors = [r for r in read_log(result.log_path) if r.get("event") == "hook_error"]
    assert len(errors) == 4 and errors[0]["plugin"] == "broken"
    assert capsys.readouterr().err.count("monitor bug") == 1


def test_interrupt_hook_sees_the_reason():
    manager = PluginManager(autoload=False)
    watcher = Watcher()
    manager.register(watcher, "watcher")
    beacon = Beacon("watch", at=2)
    run(Tree(name="t", root=beacon, source=None), rig=fake_rig(), manager=manager, record=False)
    assert watcher.reasons == [("e-stop pressed", 2)]


def test_a_caller_owned_rig_is_stopped_but_not_closed():
    rig = fake_rig()
    closed = []
    rig.closers.append(lambda: closed.append(True))
    run(Tree(name="t", root=Beacon("w", at=1), source=None), rig=rig, record=False)
    assert closed == [] and rig.arm.commands == [("arm.stop",)]
    run(
        Tree(name="t", root=py_trees.behaviours.Success("s"), source=None),
        rig=rig,
        record=False,
        close_rig=True,
    )
    assert closed == [True]


def test_a_component_step_that_raises_ends_the_run_safely():
    rig = fake_rig()

    def emulator(now):
        if now >= 0.1:
            raise HardwareFault("limit switch hit on joint 2", "sim")

    rig.steppers.append(emulator)
    move = Move("reach")
    result = run(Tree(name="t", root=move, source=None), rig=rig, record=False)
    assert result.status == "FAILURE" and result.exit_code == 3
    assert "limit switch" in result.message and result.ticks == 3
    assert rig.arm.commands == [("start", "reach"), ("halt", "reach"), ("arm.stop",)]
