"""The run log's records and what the terminal shows: live view, plain lines, summary."""

import io
import itertools

import py_trees
from py_trees.common import Status
from rich.console import Console

from armtree.loader.tree import Tree
from armtree.runtime import display, runlog
from armtree.runtime.display import LiveView, NullView, PlainView, make_view, summary
from armtree.runtime.run_end import RunResult
from armtree.runtime.runlog import RunLog, default_run_dir, jsonable, read_log
from armtree.runtime.runner import Run, run


def test_log_records_status_changes_blackboard_writes_and_the_result(tmp_path):
    write = py_trees.behaviours.SetBlackboardVariable(
        name="remember", variable_name="target", variable_value=[1.5, 2, 3], overwrite=True
    )
    wait = py_trees.behaviours.TickCounter(
        name="wait", duration=1, completion_status=Status.SUCCESS
    )
    root = py_trees.composites.Sequence("Root", memory=True, children=[write, wait])
    tree = Tree(name="mem", root=root, source=None, blackboard={"speed": 0.5})
    result = run(tree, record=tmp_path / "log", seed=3)
    log = read_log(result.log_path)
    assert result.log_path == tmp_path / "log" / "run.jsonl"
    start = log[0]
    assert start["kind"] == "start" and start["tree"] == "mem" and start["seed"] == 3
    assert start["clock"] == "virtual" and start["blackboard"] == {"speed": 0.5}
    writes = [r for r in log if r["kind"] == "blackboard"]
    assert writes and writes[0]["key"] == "/target" and writes[0]["value"] == [1.5, 2, 3]
    assert writes[0]["tick"] == 1 and writes[0]["client"] == "remember"
    statuses = [(r["tick"], r["node"], r["from"], r["to"]) for r in log if r["kind"] == "status"]
    assert statuses == [
        (1, "Root/remember", "INVALID", "SUCCESS"),
        (1, "Root/wait", "INVALID", "RUNNING"),
        (1, "Root", "INVALID", "RUNNING"),
        (2, "Root/wait", "RUNNING", "SUCCESS"),
        (2, "Root", "RUNNING", "SUCCESS"),
    ]
    assert log[-1] == {
        "kind": "result",
        "tick": 2,
        "t": 0.05,
        "status": "SUCCESS",
        "ticks": 2,
        "seconds": 0.05,
        "wall_seconds": log[-1]["wall_seconds"],
        "overruns": 0,
        "message": "",
        "failed_node": None,
        "exit_code": 0,
        "running": [],
        "verdict": "success",
        "expectations": [],
        "chain": [],
        "absorbed": [],
        "events": [],
    }


def test_default_run_dirs_are_unique_under_runs(tmp_path):
    a = default_run_dir("load ducky", tmp_path / "runs")
    b = default_run_dir("load ducky", tmp_path / "runs")
    assert a != b and a.parent == b.parent == tmp_path / "runs"
    assert a.name.startswith("load_ducky-") and a.is_dir() and b.is_dir()


def test_jsonable_keeps_structure_and_reprs_the_rest():
    import numpy as np

    assert jsonable({"a": (1, 2.5), "b": np.array([1.0, 2.0])}) == {"a": [1, 2.5], "b": [1.0, 2.0]}
    assert jsonable(float("nan")) == "nan"
    assert jsonable(object()).startswith("<object")


def test_status_lines_are_valid_json_even_with_odd_names(tmp_path):
    log = RunLog(tmp_path / "x.jsonl")
    log.status_changes(3, 0.15, [('a "quoted"\\ name', "RUNNING", "SUCCESS")])
    log.close()
    (rec,) = read_log(tmp_path / "x.jsonl")
    assert rec["node"] == 'a "quoted"\\ name' and rec["to"] == "SUCCESS" and rec["t"] == 0.15


def test_status_diff_logs_the_changed_nodes_like_status_changes(tmp_path):
    paths = ("r", "r/a", 'r/"b"', "r/c")
    run_, ok, inv = Status.RUNNING, Status.SUCCESS, Status.INVALID
    ticks = [
        [inv] * 4,
        [run_, ok, run_, inv],
        [run_, run_, ok, inv],
        [run_, ok, run_, inv],  # every transition seen before
        [run_, ok, run_, inv],  # nothing changed
        [run_, run_, ok, inv],  # the same whole-tree changes as tick 2
        [Status.FAILURE, inv, inv, inv],
    ]
    logs = {name: RunLog(tmp_path / f"{name}.jsonl") for name in ("tuples", "lists", "plain")}
    for tick, (old, new) in enumerate(itertools.pairwise(ticks), start=1):
        t = tick * 0.05
        # Names as the runtime reads them, and equal names that are different objects.
        names = tuple(s._value_ for s in old), tuple("".join(list(s.value)) for s in new)
        logs["tuples"].status_diff(tick, t, paths, *names)
        logs["lists"].status_diff(tick, t, list(paths), *map(list, names))
        changes = [(p, o.value, n.value) for p, o, n in zip(paths, old, new, strict=True) if o != n]
        logs["plain"].status_changes(tick, t, changes)
    for log in logs.values():
        log.close()
    expected = (tmp_path / "plain.jsonl").read_bytes()
    assert (tmp_path / "tuples.jsonl").read_bytes() == expected
    assert (tmp_path / "lists.jsonl").read_bytes() == expected
    records = read_log(tmp_path / "tuples.jsonl")
    assert [(r["tick"], r["node"], r["from"], r["to"]) for r in records] == [
        (1, "r", "INVALID", "RUNNING"),
        (1, "r/a", "INVALID", "SUCCESS"),
        (1, 'r/"b"', "INVALID", "RUNNING"),
        (2, "r/a", "SUCCESS", "RUNNING"),
        (2, 'r/"b"', "RUNNING", "SUCCESS"),
        (3, "r/a", "RUNNING", "SUCCESS"),
        (3, 'r/"b"', "SUCCESS", "RUNNING"),
        (5, "r/a", "SUCCESS", "RUNNING"),
        (5, 'r/"b"', "RUNNING", "SUCCESS"),
        (6, "r", "RUNNING", "FAILURE"),
        (6, "r/a", "RUNNING", "INVALID"),
        (6, 'r/"b"', "SUCCESS", "INVALID"),
    ]
    assert records[3]["t"] == 0.1 and records[7]["t"] == 0.25


def _diff_log(path, paths, sequence):
    log = RunLog(path)
    sizes = []
    for tick, (old, new) in enumerate(sequence, start=1):
        log.status_diff(tick, tick / 10, paths, old, new)
        sizes.append(len(log._ticks))
    log.close()
    expected = [
        (tick, p, o, n)
        for tick, (old, new) in enumerate(sequence, start=1)
        for p, o, n in zip(paths, old, new, strict=True)
        if o != n
    ]
    got = [(r["tick"], r["node"], r["from"], r["to"]) for r in read_log(path)]
    assert got == expected
    return log, sizes


def test_status_diff_remembers_tick_patterns_only_while_they_repeat(tmp_path):
    paths = ("a", "b", "c")
    names = ["RUNNING", "SUCCESS", "FAILURE", "INVALID"]
    # 4,096 different whole-tree transitions, more than the log remembers.
    pairs = list(itertools.product(itertools.product(names, repeat=3), repeat=2))
    never = [pairs[(tick * 7) % len(pairs)] for tick in range(600)]
    log, sizes = _diff_log(tmp_path / "never.jsonl", paths, never)
    assert max(sizes) == runlog._TICK_PATTERNS and not log._remember and sizes[-1] == 1
    cycle = [pairs[(tick % 200) * 7] for tick in range(1500)]  # 200 patterns, again and again
    log, sizes = _diff_log(tmp_path / "cycle.jsonl", paths, cycle)
    assert log._remember and max(sizes) == 200 and log._tick_hits == 1300
    # Lists are diffed alike, never remembered; tuples after lists neither.
    mixed = [tuple(map(list, pair)) for pair in pairs[:50]] + pairs[50:100]
    log, sizes = _diff_log(tmp_path / "mixed.jsonl", list(paths), mixed)
    assert max(sizes) == 0


def test_plain_view_prints_status_changes():
    out = io.StringIO()
    node = py_trees.behaviours.TickCounter(name="c", duration=1, completion_status=Status.SUCCESS)
    run(Tree(name="t", root=node, source=None), record=False, view=PlainView(out))
    lines = out.getvalue().splitlines()
    assert lines[0] == "run t: 20 Hz on the virtual clock"
    assert lines[1:] == [
        "tick 1 t=0.000s c: INVALID -> RUNNING",
        "tick 2 t=0.050s c: RUNNING -> SUCCESS",
    ]


def test_make_view_picks_by_quiet_and_terminal():
    assert type(make_view(True)) is NullView
    assert type(make_view(False, io.StringIO())) is PlainView


class FakeTty(io.StringIO):
    def isatty(self):
        return True


def test_make_view_is_live_on_a_terminal():
    assert type(make_view(False, FakeTty())) is LiveView


def test_live_view_draws_the_tree_and_refreshes_at_most_max_hz(monkeypatch):
    ticks = itertools.count()
    # A fake wall clock that moves 1 ms per reading: 1,000 updates span one second.
    monkeypatch.setattr(display.time, "monotonic", lambda: next(ticks) * 0.001)
    out = io.StringIO()
    view = LiveView(Console(file=out, force_terminal=True, width=100), max_hz=10)
    a = py_trees.behaviours.Success(name="first step")
    b = py_trees.behaviours.Running(name="second step")
    root = py_trees.composites.Sequence("Job", memory=True, children=[a, b])
    r = Run(Tree(name="job", root=root, source=None), record=False, view=view)
    r._index_nodes()
    view.start(r)
    redraws = []
    original = view._live.update
    monkeypatch.setattr(
        view._live, "update", lambda *a, **k: (redraws.append(1), original(*a, **k))
    )
    for _ in range(1000):
        view.update(r, [("Job", "INVALID", "RUNNING")])
    assert 8 <= len(redraws) <= 11
    root.tick_once()
    view.stop(r)
    text = out.getvalue()
    assert "Job" in text and "first step" in text and "second step" in text
    assert "✓" in text and "*" in text


def test_summary_names_result_times_and_why():
    result = RunResult(
        status="FAILURE",
        ticks=40,
        seconds=2.0,
        wall_seconds=0.01,
        overruns=2,
        message="timeout: 2 s on the run clock reached",
        failed_node="Root/pick",
        exit_code=1,
    )
    text = summary(result)
    assert "result: FAILURE  (exit 1)" in text
    assert "ticks: 40" in text and "run time: 2.000 s" in text and "overruns: 2" in text
    assert "failed: Root/pick" in text and "why: timeout" in text


def test_the_printed_summary_never_wraps_long_paths():
    out = io.StringIO()
    long = "/very/long/" + "directory/" * 20 + "tree.yaml:7"
    result = RunResult(
        status="FAILURE", ticks=1, seconds=0.0, message=f"ZeroDivisionError at {long}", exit_code=1
    )
    display.print_summary(result, out)
    assert long in out.getvalue()


class _Refuses(py_trees.behaviour.Behaviour):
    def update(self) -> Status:
        self.feedback_message = "no ducky seen"
        return Status.FAILURE


def test_a_composite_that_fails_is_logged_with_the_child_that_failed_and_why(tmp_path):
    inverted = py_trees.decorators.Inverter("Never", child=py_trees.behaviours.Success("Ok"))
    inner = py_trees.composites.Sequence("Look", memory=True, children=[_Refuses("Find")])
    tries = py_trees.composites.Selector("Tries", memory=True, children=[inverted, inner])
    root = py_trees.composites.Sequence("Root", memory=True, children=[tries])
    result = run(Tree(name="why", root=root, source=None), record=tmp_path / "log")
    why = {
        r["node"]: r.get("why")
        for r in read_log(result.log_path)
        if r["kind"] == "status" and r["to"] == "FAILURE"
    }
    assert why == {
        "Root/Tries/Never": "success -> failure",  # the inverter says why itself
        "Root/Tries/Look/Find": "no ducky seen",
        "Root/Tries/Look": "'Find' failed: no ducky seen",
        "Root/Tries": "'Look' failed: 'Find' failed: no ducky seen",
        "Root": "'Tries' failed: 'Look' failed: 'Find' failed: no ducky seen",
    }
    # the failure chain names each node once, with its own reason only
    assert [(f.name, f.reason) for f in result.chain] == [
        ("Root", ""),
        ("Tries", ""),
        ("Look", ""),
        ("Find", "no ducky seen"),
    ]
