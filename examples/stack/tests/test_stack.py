"""The stack package: loaded through its entry point, its tree stacks the blocks in the
simulated world (nominal and moved), and its height check fails when the stack is short."""

from __future__ import annotations

import json
from pathlib import Path

import armtree
import pytest
from armtree.cli.commandline import run_tree_main
from armtree.hooks.plugin_checks import deep_problems
from armtree.hooks.plugin_manager import get_plugin_manager

ROOT = Path(__file__).resolve().parents[1]
TREE = ROOT / "trees" / "stack.yaml"
PROFILE = ROOT / "hardware" / "sim_stack.yaml"


def run(tmp_path: Path, *options: str, tree: Path = TREE) -> tuple[int, str, dict]:
    code = run_tree_main([str(tree), "--quiet", "--record", str(tmp_path), *options])
    score = json.loads((tmp_path / "score.json").read_text())
    return code, (tmp_path / "run.jsonl").read_text(), score


def test_armtree_finds_the_behaviours_through_the_entry_point():
    registry = get_plugin_manager().registry
    for name in ("stack", "stack_height"):
        component = registry.get("behaviour", name)
        assert component.distribution == "armtree-stack"
        assert deep_problems(component) == []


@pytest.mark.parametrize(
    "moved",
    [
        [],
        # blocks a few centimetres from where the profile says: found with the camera anyway
        [
            "--set",
            "world.objects.block_a.at=[235, -135]",
            "--set",
            "world.objects.block_c.at=[365, 170]",
        ],
    ],
    ids=["nominal", "moved"],
)
def test_the_tree_stacks_the_blocks_and_the_world_agrees(tmp_path, capsys, moved):
    code, log, score = run(tmp_path, *moved)
    assert code == 0, capsys.readouterr().out
    objects = score["objects"]
    assert [objects[b]["on"] for b in ("block_a", "block_b", "block_c")] == [
        "table",
        "block_a",
        "block_b",
    ]
    assert [objects[b]["position_mm"][2] for b in ("block_a", "block_b", "block_c")] == [0, 25, 50]
    assert objects["block_c"]["position_mm"][:2] == pytest.approx([300, 0], abs=20)
    assert score["collision_count"] == 0 and score["held"] is None
    assert '"message": "the stack\'s top is at z = ' in log


def test_the_height_check_fails_saying_what_it_saw(tmp_path, capsys):
    tree = tmp_path / "check.yaml"
    tree.write_text(
        f"rig: {PROFILE}\nroot:\n  stack_height: {{tag: block, onto: stack_base, blocks: 3}}\n"
    )
    code = run_tree_main(
        [
            str(tree),
            "--quiet",
            "--record",
            str(tmp_path / "run"),
            "--set",
            "world.objects.block_a.at=[300, 0]",
        ]
    )
    out = capsys.readouterr().out
    assert code == 1
    assert "the stack's top is at z = 2" in out and "3 blocks: 75.0 mm" in out


def test_a_stack_of_nothing_is_refused_at_load(tmp_path):
    tree = tmp_path / "empty.yaml"
    tree.write_text(f"rig: {PROFILE}\nroot:\n  stack: {{tag: block, from: [], onto: stack_base}}\n")
    with pytest.raises(armtree.ConfigError, match="from: give at least one place"):
        armtree.load_tree(tree)
