"""A whole simulated run (emulator, driver, skills, tracker, world) is scored and reproducible."""

from __future__ import annotations

import json

import pytest

from armtree.loader.tree_loader import load_tree
from armtree.runtime.runner import run

WALL_CLOCK_KEYS = {"started", "wall_seconds"}


def strip(record: dict) -> dict:
    return {k: v for k, v in record.items() if k not in WALL_CLOCK_KEYS}


def pick_and_place(directory, seed):
    result = run(load_tree("pick_and_place.yaml"), seed=seed, record=directory, timeout=60)
    log = [strip(json.loads(line)) for line in (directory / "run.jsonl").read_text().splitlines()]
    score = json.loads((directory / "score.json").read_text())
    score["run"].pop("wall_seconds")
    return result, log, score


@pytest.mark.slow
def test_pick_and_place_lands_the_ducky_in_the_bin_and_repeats_exactly(tmp_path):
    first, log_a, score_a = pick_and_place(tmp_path / "a", seed=7)
    assert first.status == "SUCCESS"
    assert score_a["in_bin"] == ["ducky"] and score_a["objects"]["ducky"]["on"] == "garbage_bin"
    assert score_a["collision_count"] == 0
    _, log_b, score_b = pick_and_place(tmp_path / "b", seed=7)
    assert log_a == log_b, "same seed, same run log"
    assert score_a == score_b, "same seed, same ground truth"
