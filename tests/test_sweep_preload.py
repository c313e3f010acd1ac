"""The forker loads a sweep's tree once; every run forked from it behaves as if it loaded it."""

from __future__ import annotations

import pytest

from armtree.cli.sweep.forker import _LoadedTrees
from armtree.cli.sweep.task import RunTask

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
