"""The forker loads a sweep's tree once; every run forked from it behaves as if it loaded it."""

from __future__ import annotations

import sys

import pytest

from armtree.cli.sweep.forker import _LoadedTrees
from armtree.cli.sweep.task import RunTask, run_task

TREE = """\
tree: waits
root:
  success: {name: Done}
"""

LOUD_PLUGIN = """\
print("loud plugin imported")
"""


@pytest.fixture
def work(tmp_path, monkeypatch):
    (tmp_path / "waits.yaml").write_text(TREE)
    (tmp_path / "loud_plugin_for_preload.py").write_text(LOUD_PLUGIN)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def task(seed, **kw):
    return RunTask(tree="waits.yaml", seed=seed, run_dir=f"r{seed}", **kw)


def test_tasks_that_differ_only_in_seed_share_one_load(work):
    trees = _LoadedTrees()
    first = trees.get(task(1, rig="sim_dh"))
    assert first is not None
    manager, tree = first
    assert tree.profile is not None
    assert trees.get(task(2, rig="sim_dh")) is first
    other = trees.get(task(3, rig="sim_dobot"))
    assert other is not None and other is not first, "another rig is loaded anew"
    assert trees.get(task(4, rig="sim_dobot", overrides=("camera.noise=2",))) is not other


def test_a_load_that_fails_or_says_anything_is_left_to_the_child(work, capsys):
    trees = _LoadedTrees()
    assert trees.get(task(1, plugins=("no_such_plugin_xyz",))) is None
    assert trees.get(task(1, plugins=("loud_plugin_for_preload.py",))) is None
    assert capsys.readouterr().out == "", "nothing reaches the forker's stdout (its protocol)"


def test_the_modules_a_task_names_are_imported_before_its_runs_fork(work, monkeypatch):
    (work / "preloaded_for_runs_xyz.py").write_text("IMPORTED = True\n")
    monkeypatch.syspath_prepend(str(work))
    monkeypatch.delitem(sys.modules, "preloaded_for_runs_xyz", raising=False)
    named = task(1, preload=("preloaded_for_runs_xyz", "no_such_module_for_runs_xyz"))
    assert RunTask.from_json(named.to_json()) == named, "the names travel with the task"
    assert _LoadedTrees().get(named) is not None, "a module that fails is left to the run"
    assert sys.modules["preloaded_for_runs_xyz"].IMPORTED
    assert "no_such_module_for_runs_xyz" not in sys.modules


def test_a_dataset_sweep_asks_its_runs_process_to_load_pyav_once(work):
    from armtree.api.sweep import Sweep
    from armtree.plugins.dataset import plugin

    class Tree:
        name, tick_hz, manager, profile = "waits", 20.0, None, None

    sweep = Sweep(tree=Tree(), seeds=[1], out=work, settings={"dataset": str(work / "ds")})
    plugin.armtree_sweep_started(sweep)
    try:
        assert sweep.preload == ["av"]
    finally:
        sweep.close()
    bare = Sweep(tree=Tree(), seeds=[1], out=work, settings={})
    plugin.armtree_sweep_started(bare)
    assert bare.preload == [], "a sweep without a dataset loads nothing more"


VOLATILE = {"started", "wall_seconds", "tick_lateness_ms", "source", "sweep_run_dir", "log"}


def _stripped(value, run_dir: str):
    if isinstance(value, dict):
        return {k: _stripped(v, run_dir) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        return [_stripped(v, run_dir) for v in value]
    return value.replace(run_dir, "RUN") if isinstance(value, str) else value


def _forked_run(task: RunTask, loaded) -> list:
    """The task's run log (clock and path fields left out), run in a forked child as the
    forker runs it (``loaded``: what the forker loaded, or None to load in the child)."""
    import json
    import os
    from pathlib import Path

    pid = os.fork()
    if pid == 0:
        code = 1
        try:
            run_task(task, loaded)
            code = 0
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    log = next(Path(task.run_dir).rglob("run.jsonl"))
    return [_stripped(json.loads(line), task.run_dir) for line in log.open()]


def test_a_run_from_the_forkers_load_logs_what_a_run_that_loaded_itself_logs(tmp_path):
    # The first 6 s of a simulated load_ducky run on sim_dh: a search, a look, the emulator.
    def task(name):
        return RunTask(
            tree="load_ducky.yaml", seed=2, run_dir=str(tmp_path / name), rig="sim_dh", timeout=6.0
        )

    itself = _forked_run(task("itself"), None)
    preloaded = _LoadedTrees().get(task("preloaded"))
    assert preloaded is not None
    assert _forked_run(task("preloaded"), preloaded) == itself
    assert len(itself) > 50, "the run got somewhere"
