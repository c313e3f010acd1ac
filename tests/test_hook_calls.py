"""The runtime calls plugins through pluggy: wrappers wrap, tryfirst / trylast order, and a
plugin that raises is reported while the others are still called, once each."""

from __future__ import annotations

import py_trees
from py_trees.common import Status

import armtree
from armtree.hooks.hook_calls import call_isolated
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.tree import Tree
from armtree.runtime.runlog import read_log
from armtree.runtime.runner import run


class Plain:
    def __init__(self, name: str, calls: list[str], fail: bool = False) -> None:
        self.name, self.calls, self.fail = name, calls, fail

    def armtree_tick(self, run) -> None:
        self.calls.append(self.name)
        if self.fail:
            raise RuntimeError(f"{self.name} is broken")


def _plugin(name: str, calls: list[str], fail: bool = False, **marks) -> object:
    """A plugin object whose armtree_tick carries the hookimpl ``marks``."""

    class P(Plain):
        @armtree.hookimpl(**marks)
        def armtree_tick(self, run) -> None:
            Plain.armtree_tick(self, run)

    return P(name, calls, fail)


class Wrapper:
    def __init__(self, calls: list[str]) -> None:
        self.calls = calls

    @armtree.hookimpl(wrapper=True)
    def armtree_tick(self, run):
        self.calls.append("<")
        try:
            return (yield)
        finally:
            self.calls.append(">")


def _run(manager: PluginManager, tmp_path, ticks: int = 2):
    counter = py_trees.behaviours.TickCounter(
        name="c", duration=ticks - 1, completion_status=Status.SUCCESS
    )
    return run(Tree(name="t", root=counter, source=None), manager=manager, record=tmp_path)


def test_tick_hooks_run_in_pluggy_order_inside_a_wrapper(tmp_path):
    calls: list[str] = []
    manager = PluginManager(autoload=False)
    # registered in an order unlike the call order, to see pluggy's ordering apply
    manager.register(_plugin("last", calls, trylast=True), "last")
    manager.register(Wrapper(calls), "wrapper")
    manager.register(_plugin("first", calls, tryfirst=True), "first")
    manager.register(_plugin("middle", calls), "middle")
    result = _run(manager, tmp_path, ticks=2)
    assert result.status == "SUCCESS" and result.ticks == 2
    assert calls == ["<", "first", "middle", "last", ">"] * 2


def test_a_raising_plugin_is_reported_and_every_other_plugin_is_called_once(tmp_path, capsys):
    calls: list[str] = []
    manager = PluginManager(autoload=False)
    manager.register(_plugin("last", calls, trylast=True), "last")
    manager.register(_plugin("broken", calls, fail=True), "broken")
    manager.register(_plugin("first", calls, tryfirst=True), "first")
    result = _run(manager, tmp_path, ticks=3)
    assert result.status == "SUCCESS"
    assert calls == ["first", "broken", "last"] * 3
    errors = [r for r in read_log(result.log_path) if r.get("event") == "hook_error"]
    assert [e["plugin"] for e in errors] == ["broken"] * 3
    assert "broken is broken" in errors[0]["error"]
    assert capsys.readouterr().err.count("broken is broken") == 1


def test_a_firstresult_hook_answers_with_the_first_plugin_that_does_not_raise():
    class Answer:
        def __init__(self, value):
            self.value = value

        @armtree.hookimpl
        def armtree_ground_truth(self, run):
            if self.value is None:
                raise RuntimeError("no truth here")
            return self.value

    manager = PluginManager(autoload=False)
    manager.register(Answer("second"), "second")
    manager.register(Answer(None), "raises")
    errors: list[tuple[str, str]] = []
    answer = call_isolated(
        manager.pm, "armtree_ground_truth", lambda h, p, e: errors.append((h, p)), run=None
    )
    assert answer == "second"
    assert errors == [("armtree_ground_truth", "raises")]
