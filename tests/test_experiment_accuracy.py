"""``armtree experiment accuracy``: Durovic 2017's Tables I-III and Showers 2016's model validation,
run on the simulation and judged by its measuring device (the world's truth)."""

from __future__ import annotations

import argparse
import csv

import numpy as np
import pytest

import armtree
from armtree.plugins.calibration.experiment import (
    ExperimentCommand,
    corrected,
    statistics,
    write_report,
)

E2H = "sim_dobot_eye_to_hand"


def experiment(*argv: str) -> int:
    parser = argparse.ArgumentParser()
    ExperimentCommand().configure(parser)
    return ExperimentCommand().run(parser.parse_args(["accuracy", *argv]))


def test_statistics_are_the_papers_rows():
    diff = np.array([[3.0, -4.0], [0.0, 1.0], [-1.0, 0.0]])
    s = statistics(diff)
    assert s["dx_max"] == pytest.approx(3.0) and s["dy_max"] == pytest.approx(4.0)
    assert s["d_max"] == pytest.approx(5.0)
    assert s["sd"] == pytest.approx(np.std([5.0, 1.0, 1.0], ddof=1))


def test_the_linear_correction_removes_a_scale_and_bias_held_out_too():
    rng = np.random.default_rng(1)
    truth = rng.uniform(100, 250, (40, 3))
    measured = truth.copy()
    measured[:, 0] = 1.03 * truth[:, 0] - 4.0
    measured[:, 1] = 0.98 * truth[:, 1] + 2.5
    measured[:, :2] += rng.normal(0, 0.05, (40, 2))
    in_sample, held = corrected(measured, truth)
    before = statistics(truth - measured)
    assert before["d_max"] > 3.0
    assert statistics(in_sample)["d_max"] < 0.3 and statistics(held)["d_max"] < 0.4


def test_servo_experiment_corrects_a_missed_step_and_reports_beside_the_paper(tmp_path):
    out = tmp_path / "exp"
    slip = "world.faults={missed_steps: {joint: 1, amount: 2}}"  # slips at once: never reported
    code = experiment("--rig", E2H, "--only", "servo", "--targets", "2", "--tolerance-mm", "1",
                      "--out", str(out), "--set", slip)  # fmt: skip
    assert code == 0
    rows = list(csv.DictReader((out / "servo.csv").open()))
    assert len(rows) == 2
    for row in rows:
        # the measuring device's distance between the tool and the target's centre
        assert row["success"] == "True" and float(row["distance_xy"]) < 1.5, row
    assert int(rows[0]["iterations"]) >= 1  # the slip was corrected by closing the loop
    report = (out / "report.md").read_text()
    assert "Table III" in report and "| Δd_max [mm] |" in report and "| 6.0 |" in report
    assert (out / "servo_histogram.png").stat().st_size > 5000


def test_grid_homes_and_measures_again_a_point_where_steps_slipped(tmp_path):
    # theta1 slips often (seeded: the same slips every run), never reported by the firmware
    out = tmp_path / "grid"
    slips = "world.faults={missed_steps: {rate_per_s: 0.2, max_amount: 1.0, joints: [1]}}"
    code = experiment("--rig", "sim_vicra", "--only", "grid", "--grid", "3", "--out", str(out),
                      "--set", slips)  # fmt: skip
    assert code == 0
    rows = list(csv.DictReader((out / "grid.csv").open()))
    assert len(rows) == 9 and sum(int(r["redone"]) for r in rows) >= 1
    assert all(float(r["disagreement_mm"]) < 0.5 for r in rows)
    # every point kept is where the arm believed it was, as the measuring device says
    error = [np.hypot(float(r["truth_x"]) - float(r["commanded_x"]),
                      float(r["truth_y"]) - float(r["commanded_y"])) for r in rows]  # fmt: skip
    assert max(error) < 0.6
    assert (
        "homed on its own reference and measured the point again" in (out / "report.md").read_text()
    )


def test_grid_on_the_dobot_v1_undoes_a_slip_by_resetting_the_board(tmp_path):
    # no end stops on the Dobot V1.0: its homing resets the board, whose accelerometers
    # read the rear arm's true angle again (to within a count, 0.67 deg near home)
    out = tmp_path / "g"
    slip = "world.faults={missed_steps: {joint: 1, amount: 2}}"
    code = experiment("--rig", E2H, "--only", "grid", "--grid", "2", "--out", str(out),
                      "--set", slip)  # fmt: skip
    assert code == 0
    rows = list(csv.DictReader((out / "grid.csv").open()))
    assert len(rows) == 4 and int(rows[0]["redone"]) == 1
    assert all(float(r["disagreement_mm"]) < 0.5 for r in rows)
    error = [np.hypot(float(r["truth_x"]) - float(r["commanded_x"]),
                      float(r["truth_y"]) - float(r["commanded_y"])) for r in rows]  # fmt: skip
    assert max(error) < 1.0  # 4.7 mm before the reset: the 2 degree slip of the rear arm


def test_model_validation_on_vicra_plans_poses_that_touch_nothing(tmp_path):
    # sim_vicra as shipped: a crate within the links' reach, objects on the table
    out = tmp_path / "val"
    code = experiment("--rig", "sim_vicra", "--only", "validation", "--poses", "6",
                      "--out", str(out))  # fmt: skip
    assert code == 0  # a collision halts the run: the tree would fail
    rows = list(csv.DictReader((out / "validation.csv").open()))
    assert len(rows) == 6 and all(float(r["before_mm"]) < 1.0 for r in rows)


def test_report_puts_each_table_beside_the_seeds_figures(tmp_path):
    stats = statistics(np.array([[1.0, 0.5], [0.2, -0.3], [-0.4, 0.1]]))
    results = {
        "rig": "r",
        "grid": {"points": 3, "seen": 3, "I": {"before": stats, "after": stats, "held_out": stats}},
        "validation": {"points": 5, "before": (1.0, 0.5), "after": (0.5, 0.2),
                       "held_out": (0.6, 0.3), "params": {}},
    }  # fmt: skip
    text = write_report(results, tmp_path).read_text()
    assert "| Δy_max [mm] | 0.50 | 0.50 | 0.50 | 14.61 | 2.3 |" in text
    assert "| Showers 2016, 27 points | 3.08 ± 1.55 | 2.2 ± 1.13 | - |" in text


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--targets", "0"], "--targets 0: too few"),
        (["--grid", "1"], "--grid 1: too few"),
        (["--slip-mm", "-1"], "--slip-mm -1: a distance"),
    ],
)
def test_bad_options_are_refused_before_anything_moves(tmp_path, argv, message):
    with pytest.raises(armtree.ConfigError, match=message):
        experiment("--rig", E2H, "--out", str(tmp_path / "x"), *argv)
    assert not (tmp_path / "x").exists()
