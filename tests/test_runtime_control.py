"""Pause, step one tick, resume, stop and pace a run through ``run.control`` and the keys."""

import os
import pty
import threading
import time

import numpy as np
import py_trees
import pytest
from test_interrupt_signals import EXIT_S, Proc

import armtree
from armtree.api.clock import WallClock
from armtree.api.rig import Rig
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.tree import Tree
from armtree.runtime.control import RunControl
from armtree.runtime.interrupts import Interrupts
from armtree.runtime.runlog import read_log
from armtree.runtime.runner import Run


class Driver:
    """A lifecycle plugin that asks for a pause after tick ``pause_at`` (from the tick hook,
    so a fast virtual clock cannot outrun it), runs ``script(run)`` on a thread once the
    run starts, and keeps what the hooks saw."""

    def __init__(self, script=None, pause_at=None):
        self.script = script
        self.pause_at = pause_at
        self.paused_calls = []
        self.thread = None
        self.error = None

    @armtree.hookimpl
    def armtree_run_started(self, run):
        if self.script is not None:
            self.thread = threading.Thread(target=self._go, args=(run,), daemon=True)
            self.thread.start()

    def _go(self, run):
        try:
            self.script(run)
        except BaseException as exc:  # noqa: BLE001 - reported by the test
            self.error = exc
            run.control.stop("script failed")

    @armtree.hookimpl
    def armtree_tick(self, run):
        if run.tick_count == self.pause_at:
            run.control.pause()

    @armtree.hookimpl
    def armtree_run_paused(self, run, paused):
        self.paused_calls.append((paused, run.tick_count, run.clock.now()))


def spin_tree():
    return Tree(name="spin", root=py_trees.behaviours.Running(name="Spin"), source=None)


def run_with(driver, tree=None, rig=None, **kwargs):
    manager = PluginManager(autoload=False)
    manager.register(driver, "driver")
    run = Run(tree or spin_tree(), rig, manager=manager, handle_signals=False, **kwargs)
    result = run.execute()
    if driver.thread is not None:
        driver.thread.join(5)
    if driver.error is not None:
        raise driver.error
    return run, result


def wait_until(predicate, timeout=5.0):
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.005)


def test_pause_holds_the_tick_and_the_clock_step_runs_one_tick_resume_goes_on(tmp_path):
    seen = {}

    def script(run):
        wait_until(lambda: run.control.state == "paused")
        held = (run.tick_count, run.clock.now())
        time.sleep(0.15)
        seen["held"] = held
        seen["after_wait"] = (run.tick_count, run.clock.now())
        run.control.step()
        wait_until(lambda: run.control.state == "paused" and run.tick_count == held[0] + 1)
        seen["stepped"] = run.tick_count
        run.control.resume()

    run, result = run_with(Driver(script, pause_at=3), max_ticks=40, record=tmp_path)
    assert seen["held"][0] == 3
    assert seen["after_wait"] == seen["held"]
    assert seen["stepped"] == seen["held"][0] + 1
    assert result.status == "FAILURE" and result.ticks == 40  # max ticks: it went on
    events = [r["event"] for r in read_log(tmp_path / "run.jsonl") if r["kind"] == "event"]
    assert events == ["paused", "step", "paused", "resumed"]


def test_the_paused_hook_sees_the_hold_and_the_release(tmp_path):
    def script(run):
        wait_until(lambda: run.control.paused)
        run.control.resume()

    driver = Driver(script, pause_at=1)
    run_with(driver, max_ticks=10, record=False)
    assert [p for p, _, _ in driver.paused_calls] == [True, False]
    assert driver.paused_calls[0][1] == driver.paused_calls[1][1]  # no tick in between


def test_a_wall_clock_stands_still_while_paused():
    tree = Tree(name="spin", root=py_trees.behaviours.Running(name="Spin"), source=None)
    tree.tick_hz = 50
    hold_s = 0.4
    seen = {}

    def script(run):
        wait_until(lambda: run.tick_count >= 2)
        run.control.pause()
        wait_until(lambda: run.control.paused)
        paused_at = run.tick_count
        t, wall = run.clock.now(), time.monotonic()
        time.sleep(hold_s)
        seen["held"] = run.clock.now() - t
        run.control.resume()
        wait_until(lambda: run.tick_count > paused_at)  # released and ticking again
        # clock first, wall second: wall_gap covers clock_gap plus the time held
        seen["clock_gap"], seen["wall_gap"] = run.clock.now() - t, time.monotonic() - wall

    start = time.monotonic()
    run, result = run_with(Driver(script), tree=tree, realtime=True, max_ticks=10, record=False)
    wall = time.monotonic() - start
    assert seen["held"] == 0.0, "the clock stood still while paused"
    # Released, it runs on from where it stood: the time held is not run time. Both gaps
    # are read on this thread, so this holds however late the ticks are on a busy machine.
    assert seen["clock_gap"] > 0.0
    assert seen["wall_gap"] - seen["clock_gap"] >= hold_s - 1e-6
    assert result.ticks == 10 and result.seconds <= wall - hold_s + 1e-6


class BusyArm:
    """An arm whose command is under way until ``free`` is set."""

    def __init__(self):
        self.free = threading.Event()
        self.stopped = 0

    def busy(self):
        return not self.free.is_set()

    def stop(self):
        self.stopped += 1


def test_on_a_wall_clock_the_pause_waits_for_the_arm_to_finish_its_command():
    arm = BusyArm()
    rig = Rig(profile=None, clock=WallClock(), arm=arm)
    seen = {}

    def script(run):
        wait_until(lambda: run.tick_count >= 2)
        run.control.pause()
        time.sleep(0.2)
        seen["pausing"] = (run.control.state, run.tick_count)
        arm.free.set()
        wait_until(lambda: run.control.paused)
        seen["paused_at"] = run.tick_count
        seen["arm_stops"] = arm.stopped
        run.control.stop("page")

    tree = spin_tree()
    tree.tick_hz = 50
    run, result = run_with(Driver(script), tree=tree, rig=rig, record=False)
    state, ticks = seen["pausing"]
    assert state == "pausing" and ticks > 4  # it kept ticking while the arm moved
    assert seen["paused_at"] >= ticks
    assert seen["arm_stops"] == 0  # a pause stops nothing: the arm is idle and still owned
    assert (result.status, result.exit_code, result.reason) == ("INTERRUPTED", 130, "page")


def test_stop_while_paused_is_the_safe_stop_of_ctrl_c(tmp_path):
    def script(run):
        wait_until(lambda: run.control.paused)
        run.control.stop("stop from the page")

    run, result = run_with(Driver(script, pause_at=2), record=tmp_path)
    assert (result.status, result.exit_code) == ("INTERRUPTED", 130)
    assert result.running == ["Spin"]
    log = read_log(tmp_path / "run.jsonl")
    assert any(r.get("event") == "interrupt" and r["reason"] == "stop from the page" for r in log)
    assert log[-1]["status"] == "INTERRUPTED"


def test_speed_paces_a_virtual_clock_to_the_wall_and_keeps_it_deterministic():
    tree = spin_tree()
    tree.tick_hz = 50
    manager = PluginManager(autoload=False)
    run = Run(tree, manager=manager, handle_signals=False, max_ticks=11, record=False)
    run.control.speed = 2.0
    start = time.monotonic()
    result = run.execute()
    # 10 periods of 20 ms of run time at twice real time: at least 0.1 s of wall time.
    assert time.monotonic() - start >= 0.1 - 1e-3
    assert result.seconds == pytest.approx(11 * 0.02, abs=1e-9)  # the same as unpaced
    with pytest.raises(ValueError, match="positive"):
        run.control.speed = 0


def test_terminal_keys_map_to_the_control():
    interrupts = Interrupts()
    control = RunControl(interrupts)
    states = []
    control.listeners.append(states.append)
    control.key("p")
    assert control.state == "pausing"
    control.enter()
    control.key("n")
    assert control.leave() is True  # the step is granted once
    assert control.state == "pausing"
    control.key("r")
    assert control.state == "running"
    control.key(" ")
    control.key(" ")
    assert control.state == "running"
    assert not interrupts.requested
    control.key("xq")
    assert interrupts.reason == "stop key"
    assert states[0] == "pausing" and "paused" in states


class Refuse:
    @armtree.hookimpl
    def armtree_run_opening(self, run):
        run.closers.append(lambda: closed.append(True))
        raise armtree.ConfigError("--thing: refused")


closed = []


def test_a_plugin_refuses_the_run_before_anything_is_built_and_its_closers_run(tmp_path):
    manager = PluginManager(autoload=False)
    manager.register(Refuse(), "refuse")
    closed.clear()
    with pytest.raises(armtree.ConfigError, match="refused"):
        Run(spin_tree(), manager=manager, record=tmp_path, handle_signals=False).execute()
    assert closed == [True]
    assert not (tmp_path / "run.jsonl").exists()


def test_keys_in_a_terminal_pause_step_and_stop_a_real_run(tmp_path):
    (tmp_path / "spin.yaml").write_text(
        "tree: spin\ntick_hz: 20\nroot:\n  sequence:\n    name: Root\n    children:\n"
        "      - success: {name: Ready}\n      - running: {name: Wait}\n"
    )
    master, slave = pty.openpty()
    try:
        proc = Proc(["spin.yaml", "--record", "rec", "--realtime"], tmp_path, stdin=slave)
        proc.wait_for("Root/Wait: INVALID -> RUNNING")
        os.write(master, b"p")
        line = proc.wait_for("paused after tick")
        held = int(line.split("paused after tick ")[1].split(":")[0])
        os.write(master, b"n")
        proc.wait_for(f"paused after tick {held + 1}:")
        os.write(master, b"q")
        code, err = proc.finish(timeout=EXIT_S)
    finally:
        os.close(slave)
        os.close(master)
    assert code == 130 and "interrupted by stop key" in err
    log = read_log(tmp_path / "rec" / "run.jsonl")
    events = [(r["event"], r["tick"]) for r in log if r["kind"] == "event"]
    assert events[:3] == [("paused", held), ("step", held), ("paused", held + 1)]
    assert log[-1]["status"] == "INTERRUPTED"
    assert np.all(np.diff([r["t"] for r in log if "t" in r]) >= 0)
