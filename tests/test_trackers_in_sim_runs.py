"""load_ducky with every tracker on every simulated rig (a few seeds; docs/benchmarks.md has
the sweeps), and a run whose markers are of another family than its tracker's."""

from __future__ import annotations

import pytest

from armtree import load_tree
from armtree.cli.commandline import run_tree_main
from armtree.config.resolve import available
from armtree.plugins.trackers.families import tracker_family
from armtree.runtime.runlog import read_log

#: One run per rig, the trackers and both AprilTag spellings spread across them.
RUNS = [
    ("sim_dobot", "tracker.type=hamming", 10007),
    ("sim_vicra", "tracker.type=apriltag", 10013),
    ("sim_magician", "tracker.dictionary=apriltag_36h11", 10021),
    ("sim_dh", "tracker.type=hamming", 10033),
]


SIM_RIGS = ("sim_dobot", "sim_vicra", "sim_magician", "sim_dh")
TRACKERS = ("tracker.type=hamming", "tracker.type=apriltag", "tracker.dictionary=apriltag_36h11")


def result_of(directory):
    log = read_log(directory / "run.jsonl")
    assert log[-1]["kind"] == "result"
    return log[-1]


@pytest.mark.slow
@pytest.mark.parametrize(("rig", "tracker", "seed"), RUNS)
def test_load_ducky_runs_with_the_tracker(tmp_path, capsys, rig, tracker, seed):
    argv = ["load_ducky.yaml", "--rig", rig, "--seed", str(seed), "--set", tracker]
    code = run_tree_main([*argv, "--quiet", "--record", str(tmp_path / "run")])
    out = capsys.readouterr().out
    assert code == 0, out
    result = result_of(tmp_path / "run")
    assert result["status"] == "SUCCESS" and result["verdict"] == "success"
    assert all(e["status"] == "pass" for e in result["expectations"])


@pytest.mark.slow
def test_every_shipped_tree_loads_with_every_tracker_on_every_sim_rig():
    # each (tree, rig) with one of the three settings in turn: every setting on every rig
    pairs = [(name, rig) for name in available("tree") for rig in SIM_RIGS]
    for n, (name, rig) in enumerate(pairs):
        setting = TRACKERS[n % len(TRACKERS)]
        extra = ["tag=duckybot"] if name == "search" else []
        tree = load_tree(name, rig=rig, overrides=[setting, *extra])
        family = tracker_family(tree.profile.section("tracker")).name
        assert family == ("hamming" if "hamming" in setting else "apriltag_36h11")


def test_markers_of_another_family_fail_the_search_saying_so(tmp_path, capsys):
    # the ducky's label printed in Hampy while the tracker reads ArUco 4x4_50
    tree = tmp_path / "look.yaml"
    tree.write_text("rig: sim_dobot\nroot: {look: {tag: ducky, near: ducky_pickup}}\n")
    argv = [str(tree), "--set", "world.objects.ducky.marker={family: hamming}"]
    code = run_tree_main([*argv, "--quiet", "--record", str(tmp_path / "run")])
    capsys.readouterr()
    result = result_of(tmp_path / "run")
    assert code == 1 and result["status"] == "FAILURE"
    assert "no 'ducky' tag within 80 mm" in result["message"]
    assert "decoded as nothing in family 4x4_50" in result["message"]
