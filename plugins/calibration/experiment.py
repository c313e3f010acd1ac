"""``armtree experiment accuracy --rig P [--out DIR]``: the source documents' accuracy experiments.

* Experiment 1 (Durovic 2017, Tables I and II): the tool visits a 10 x 10 grid; the
  camera's measurement of the tool and the commanded position are compared with
  the measuring device's (the truth), before and after Durovic 2017's linear
  correction (eq. 8) fitted on the same points, as the paper did, and held out.
* Experiment 2 (Table III): 30 random targets, a direct move, then visual servoing
  until within an aim inside the tolerance (which decides success); the distance
  between the tool and the target's centre as the measuring device gives it.
* Showers 2016's model validation: the tool's position at well-spread poses against the
  forward kinematics, mean ± sd before and after a least-squares fit of the tool
  offset and joint offsets (in sample, as the report, and held out).

Each part is a tree (``experiment_grid``, ``experiment_servo``, ``experiment_validation``)
run on the profile as it is, calibration files included, so it runs unchanged on
hardware where the operator is the measuring device. DIR gets ``report.md`` (each
table beside the source document's figures), scatter plots and histograms (PNG) and the raw
measurements (CSV).
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path
from typing import Any

import numpy as np
import py_trees

from armtree.api.rig import Rig
from armtree.cli.options import seed_value
from armtree.errors import ConfigError
from armtree.maths.motion.kinematic_calibration import CalibrationPoints
from armtree.maths.perception.frames import LinearCorrection

from . import fits
from .run import report, run_tree

#: Durovic 2017, Table I (tool coordinates measured by vision): before and after correction, mm.
PAPER_TABLE_I = {"dx_max": (5.94, 4.87), "dy_max": (14.61, 2.30), "d_max": (8.93, 4.64),
                 "sx": (1.80, 1.74), "sy": (4.17, 0.93), "sd": (2.61, 1.76)}  # fmt: skip
#: Durovic 2017, Table II (tool positions given to the robot).
PAPER_TABLE_II = {"dx_max": (7.00, 1.86), "dy_max": (2.00, 1.25), "d_max": (7.23, 1.75),
                  "sx": (1.95, 0.77), "sy": (0.61, 0.44), "sd": (1.95, 0.78)}  # fmt: skip
#: Durovic 2017, Table III (visual servoing): max distance and its sd, mm.
PAPER_TABLE_III = {"d_max": 6.0, "sd": 1.42}
#: Showers 2016, model validation: mean ± sd of the distance before and after the fit (mm), per dataset.
PAPER_VALIDATION = [
    ("27 points", (3.08, 1.55), (2.20, 1.13)),
    ("39 points", (1.09, 0.77), (0.55, 0.27)),
]
ROWS = [
    ("dx_max", "Δx_max"),
    ("dy_max", "Δy_max"),
    ("d_max", "Δd_max"),
    ("sx", "σ_x"),
    ("sy", "σ_y"),
    ("sd", "σ_d"),
]
PARTS = ("grid", "servo", "validation")


def write_csv(path: Path, header: list[str], rows: list[list[Any]]) -> None:
    """The raw measurements: one header row, then one row per point."""
    with path.open("w", newline="") as handle:
        w = csv.writer(handle)
        w.writerow(header)
        w.writerows(rows)


def statistics(diff: np.ndarray) -> dict[str, float]:
    """Durovic 2017's statistics of x-y differences ``(N, 2+)`` (truth minus measured), mm."""
    d = np.linalg.norm(diff[:, :2], axis=1)
    return {
        "dx_max": float(np.max(np.abs(diff[:, 0]))),
        "dy_max": float(np.max(np.abs(diff[:, 1]))),
        "d_max": float(np.max(d)),
        "sx": float(np.std(diff[:, 0], ddof=1)),
        "sy": float(np.std(diff[:, 1], ddof=1)),
        "sd": float(np.std(d, ddof=1)),
    }


def corrected(
    measured: np.ndarray, truth: np.ndarray, folds: int = 5
) -> tuple[np.ndarray, np.ndarray]:
    """Differences after eq. 8 fitted on all points (as the paper) and fitted on the other folds."""
    fit = LinearCorrection.fit(measured, truth)
    in_sample = truth - fit.apply(measured)
    held = np.empty_like(truth)
    for fold in fits.folds_of(len(truth), folds):
        train = np.setdiff1d(np.arange(len(truth)), fold)
        held[fold] = truth[fold] - LinearCorrection.fit(measured[train], truth[train]).apply(
            measured[fold]
        )
    return in_sample, held


class ExperimentCommand:
    """``armtree experiment accuracy``: Durovic 2017's Tables I-III and Showers 2016's model validation."""

    help = "the source documents' accuracy experiments: Durovic 2017's Tables I-III, Showers 2016's model validation"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add the ``accuracy`` experiment and its options."""
        from armtree.cli.options import add_set_option

        which = parser.add_subparsers(dest="experiment", metavar="EXPERIMENT", required=True)
        acc = which.add_parser(
            "accuracy", help="Tables I-III (Durovic 2017) and the model validation (Showers 2016)"
        )
        acc.add_argument("--rig", required=True, metavar="PROFILE", help="the profile to measure")
        acc.add_argument("--out", metavar="DIR", help="report folder (default experiment-PROFILE)")
        acc.add_argument(
            "--grid", type=int, default=10, help="experiment 1: points along each side"
        )
        acc.add_argument(
            "--height-mm",
            type=float,
            default=60.0,
            help="experiment 1: tool height above the table",
        )
        acc.add_argument(
            "--slip-mm",
            type=float,
            default=0.5,
            help="experiment 1: home and redo a point where the camera and the joints disagree "
            "by more (mm; 0: no check)",
        )
        acc.add_argument("--targets", type=int, default=30, help="experiment 2: targets")
        acc.add_argument(
            "--hover-mm",
            type=float,
            help="experiment 2: tool height over a target (default the profile's look height)",
        )
        acc.add_argument(
            "--tolerance-mm",
            type=float,
            default=3.0,
            help="experiment 2: a trial succeeds within this (Durovic 2017: 3)",
        )
        acc.add_argument(
            "--aim-mm",
            type=float,
            default=1.0,
            help="experiment 2: correct until within this, inside the tolerance",
        )
        acc.add_argument(
            "--poses", type=int, default=27, help="model validation: poses (Showers 2016: 27)"
        )
        acc.add_argument(
            "--only", action="append", choices=PARTS, help="run only these parts (repeatable)"
        )
        acc.add_argument(
            "--seed", type=seed_value, default=0, help="the runs' seed (sim noise, targets, poses)"
        )
        add_set_option(acc, "override a profile key (repeatable), e.g. include=calibration.yaml")

    def run(self, args: argparse.Namespace) -> int:
        """Run the parts, then write the report; 0, 1 when a part failed, ConfigError for bad input."""
        from armtree.config.workcell import workcell_of
        from armtree.loader.profile import load_profile

        for name in ("grid", "targets", "poses"):
            if getattr(args, name) < (2 if name == "grid" else 1):
                raise ConfigError(f"--{name} {getattr(args, name)}: too few")
        if args.slip_mm < 0:
            raise ConfigError(f"--slip-mm {args.slip_mm:g}: a distance, 0 or more (0: no check)")
        profile = load_profile(args.rig, args.overrides)
        out = Path(args.out or f"experiment-{profile.name}")
        out.mkdir(parents=True, exist_ok=True)
        hover = args.hover_mm if args.hover_mm is not None else workcell_of(profile).look_height_mm
        parts = args.only or list(PARTS)
        results: dict[str, Any] = {"rig": profile.name, "overrides": list(args.overrides)}
        code = 0
        run = None
        manager = getattr(args, "manager", None)

        def part(tree: str, settings: list[str], title: str) -> Rig | None:
            """Run one part's tree; the rig it ran on when it succeeded (None otherwise, the
            exit code kept)."""
            nonlocal code, run
            r, run = run_tree(tree, args.rig, args.overrides + settings, args.seed, title, manager)
            code = code or report(r, title)
            return run.rig if r.status == "SUCCESS" else None

        if "grid" in parts:
            grid = [f"grid={args.grid}", f"height_mm={args.height_mm}", f"slip_mm={args.slip_mm}"]
            rig = part("experiment_grid.yaml", grid, "experiment 1: grid")
            if rig is not None:
                results["grid"] = grid_tables(_bb("grid_views"), rig, out)
        if "servo" in parts:
            part("experiment_servo.yaml", [f"targets={args.targets}", f"hover_mm={hover}", f"seed={args.seed}",
                 f"tolerance_mm={args.tolerance_mm}", f"aim_mm={args.aim_mm}"], "experiment 2: servoing")  # fmt: skip
            trials = _bb("trials") or []
            if trials:
                results["servo"] = servo_table(trials, args.tolerance_mm, out)
                results["servo"].update(tolerance=args.tolerance_mm, aim=args.aim_mm)
        settings = [f"poses={args.poses}", f"seed={args.seed}"]
        if "validation" in parts:
            rig = part("experiment_validation.yaml", settings, "model validation")
            if rig is not None:
                results["validation"] = validation_table(_bb("validation_views"), rig, out)
        device = getattr(getattr(run, "rig", None), "reference", None)
        results["device"] = getattr(device, "description", "")
        path = write_report(results, out)
        print(f"wrote {path} and the CSV and PNG files beside it")
        return code


def _bb(key: str) -> Any:
    return py_trees.blackboard.Blackboard.storage.get(f"/{key}")


# -------------------------------------------------------------------- experiment 1


def grid_tables(observations: dict[str, Any], rig: Rig, out: Path) -> dict[str, Any]:
    """Tables I and II from the grid's observations; writes grid.csv and the scatter plot."""
    poses = observations["poses"]
    truth = np.array([p["truth"] for p in poses])
    commanded = np.array([p["commanded"] for p in poses])
    vision = fits.vision_tool_positions(poses, rig)
    pnp = fits.vision_tool_positions(poses, rig, along_ray=False)
    seen = np.all(np.isfinite(vision), axis=1)
    axes = ("x", "y", "z")
    write_csv(
        out / "grid.csv",
        [*(f"{what}_{a}" for what in ("commanded", "vision", "truth", "vision_pnp") for a in axes),
         "disagreement_mm", "redone"],
        [[*(f"{x:.4f}" for x in (*c, *v, *t, *n)), p.get("disagreement_mm", ""), p.get("redone", "")]
         for c, v, t, n, p in zip(commanded, vision, truth, pnp, poses, strict=True)],
    )  # fmt: skip
    tables: dict[str, Any] = {"points": len(poses), "seen": int(seen.sum())}
    watch = observations.get("slips")
    if watch:
        redone = sum(int(p.get("redone", 0)) > 0 for p in poses)
        tables["slips"] = {"slip_mm": watch["slip_mm"], "points": redone, "found": watch["found"],
                           "homings": watch["homings"], "unchecked": int((~seen).sum())}  # fmt: skip
    series = {}
    if seen.sum() >= 4:
        # the marker's range as PnP solved it, kept for comparison (the paper's measurement)
        tables["I_pnp"] = statistics(corrected(pnp[seen], truth[seen])[0])
    for name, measured, true in (("I", vision[seen], truth[seen]), ("II", commanded, truth)):
        if len(measured) < 4:
            tables[name] = None
            continue
        in_sample, held = corrected(measured, true)
        before = true - measured
        tables[name] = {
            "before": statistics(before),
            "after": statistics(in_sample),
            "held_out": statistics(held),
        }
        series[name] = (before, in_sample)
    scatter(series, out / "grid_errors.png")
    return tables


def scatter(series: dict[str, tuple[np.ndarray, np.ndarray]], path: Path) -> None:
    """x-y error scatter before and after the correction, one panel per table."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, max(1, len(series)), figsize=(6 * max(1, len(series)), 5))
    axes = np.atleast_1d(axes)
    titles = {"I": "Table I: truth - vision", "II": "Table II: truth - commanded"}
    for ax, (name, (before, after)) in zip(axes, series.items(), strict=False):
        ax.scatter(before[:, 0], before[:, 1], s=12, label="before correction")
        ax.scatter(after[:, 0], after[:, 1], s=12, label="after correction (eq. 8)")
        ax.axhline(0, color="grey", lw=0.5)
        ax.axvline(0, color="grey", lw=0.5)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("Δx (mm)")
        ax.set_ylabel("Δy (mm)")
        ax.set_title(titles[name])
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# -------------------------------------------------------------------- experiment 2


def servo_table(trials: list[dict[str, Any]], tolerance: float, out: Path) -> dict[str, Any]:
    """Table III from the trials; writes servo.csv and the histogram."""
    d = np.array([t["distance_xy"] for t in trials], dtype=float)
    ok = [
        not t.get("failure") and t["servo_error"] is not None and t["servo_error"] < tolerance
        for t in trials
    ]
    write_csv(
        out / "servo.csv",
        ["target_x", "target_y", "tool_x", "tool_y", "tool_z", "distance_xy", "servo_error",
         "iterations", "success", "failure"],
        [[*t["target"][:2], *t["tool"], t["distance_xy"], t["servo_error"], t["iterations"], good,
          t.get("failure", "")] for t, good in zip(trials, ok, strict=True)],
    )  # fmt: skip
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.hist(d, bins=15)
    ax.axvline(PAPER_TABLE_III["d_max"], color="red", ls="--", label="Durovic 2017's max (6 mm)")
    ax.set_xlabel("distance between tool and target centre (mm)")
    ax.set_ylabel("targets")
    ax.set_title(
        f"visual servoing, {len(d)} targets (max {d.max():.2f} mm, sd {d.std(ddof=1) if len(d) > 1 else 0:.2f} mm)"
    )
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "servo_histogram.png", dpi=100)
    plt.close(fig)
    return {
        "targets": len(d),
        "successes": int(sum(ok)),
        "d_max": float(d.max()),
        "sd": float(d.std(ddof=1)) if len(d) > 1 else 0.0,
        "mean": float(d.mean()),
        "corrections": [t["iterations"] for t in trials],
        "failures": [t.get("failure", "") for t in trials if t.get("failure")],
    }


# -------------------------------------------------------------------- Showers 2016's validation


def validation_table(observations: dict[str, Any], rig: Rig, out: Path) -> dict[str, Any]:
    """Showers 2016's mean ± sd before and after the fit; writes validation.csv and its plot."""
    unreached = [p for p in observations["poses"] if not p.get("reached", True)]
    poses = [p for p in observations["poses"] if p.get("reached", True)]
    joints = np.array([p["joints"] for p in poses])
    truth = np.array([p["truth"] for p in poses])
    make, arm, component = fits.arm_model_builder(rig)
    names = {p.name for p in component.params}
    free = tuple(k for k in ("tool_offset_mm",) if k in names)
    points = CalibrationPoints(joints, truth, "measuring device")
    from armtree.maths.motion.kinematic_calibration import fit_kinematics

    fit = fit_kinematics(
        lambda p: make({**arm, **p}), {k: float(arm[k]) for k in free}, points, free=free
    )
    before = np.linalg.norm(fit.residuals_before_mm, axis=1)
    after = np.linalg.norm(fit.residuals_after_mm, axis=1)
    held = fits.kinematic_cv(points, make, arm, free, 5)["after"]
    write_csv(
        out / "validation.csv",
        [*(f"j{i}" for i in range(joints.shape[1])), "truth_x", "truth_y", "truth_z",
         "before_mm", "after_mm", "held_out_mm"],
        [[*(f"{v:.4f}" for v in (*q, *t)), f"{b:.4f}", f"{a:.4f}", f"{h:.4f}"]
         for q, t, b, a, h in zip(joints, truth, before, after, held, strict=True)],
    )  # fmt: skip
    fits.draw({"title": "model validation (Showers 2016)", "bars": {"before fit": before.tolist(), "after fit": after.tolist(),
                                                               "held out": held.tolist()}}, str(out / "validation.png"))  # fmt: skip
    return {
        "points": len(poses),
        "unreached": [f"{p['commanded']}: {p.get('why', '')}" for p in unreached],
        "before": (float(before.mean()), float(before.std(ddof=1))),
        "after": (float(after.mean()), float(after.std(ddof=1))),
        "held_out": (float(held.mean()), float(held.std(ddof=1))),
        "params": {
            **{k: round(fit.params[k], 3) for k in free},
            "joint_offsets_deg": np.round(fit.joint_offsets_deg, 3).tolist(),
        },
    }


# -------------------------------------------------------------------- the report


def _f(v: float) -> str:
    return f"{v:.2f}"


def _slips_line(slips: dict[str, Any] | None) -> str:
    """What the check for missed steps found during the grid, for the report."""
    if not slips:
        return ("Missed steps were not checked for (`--slip-mm 0`): a step the arm missed "
                "stays in the commanded positions.")  # fmt: skip
    n = slips["points"]
    return (f"Missed steps: at each point the camera's measurement of the tool's marker was "
            f"compared with where the joints put the tool; they disagreed by more than "
            f"{slips['slip_mm']:g} mm {slips['found']} times, at {n} point{'' if n == 1 else 's'}: each "
            f"time the arm homed on its own reference and measured the point again ({slips['homings']} "
            "homings). The marker was not seen at "
            f"{slips['unchecked']} points, which were not checked. Each point's disagreement and "
            "homings are in grid.csv (`disagreement_mm`, `redone`).")  # fmt: skip


def write_report(results: dict[str, Any], out: Path) -> Path:
    """``report.md``: each table beside the source document's figures."""
    lines = [f"# Accuracy experiments on {results['rig']}", ""]
    if results.get("overrides"):
        lines += [f"Profile overrides: `{' '.join(results['overrides'])}`", ""]
    lines += [f"Ground truth: {results.get('device') or 'the measuring device'}.", ""]
    grid = results.get("grid")
    if grid:
        lines += [f"## Experiment 1: {grid['points']} grid points (Durovic 2017, Tables I and II)", "",
                  f"The camera saw the tool's marker at {grid['seen']} of them. Differences are truth minus "
                  "measurement, mm; 'after' fits eq. 8 on the same points as the paper did, 'held out' on "
                  "the other folds (5-fold).", ""]  # fmt: skip
        for name, paper, title in (
            ("I", PAPER_TABLE_I, "vision"),
            ("II", PAPER_TABLE_II, "commanded (open loop)"),
        ):
            t = grid.get(name)
            if not t:
                continue
            lines += [f"### Table {name}: {title}", ""]
            if name == "II":
                lines += [_slips_line(grid.get("slips")), ""]
            lines += [
                      "| | before | after | held out | Durovic 2017 before | Durovic 2017 after |",
                      "| --- | --- | --- | --- | --- | --- |"]  # fmt: skip
            for key, label in ROWS:
                lines.append(f"| {label} [mm] | {_f(t['before'][key])} | {_f(t['after'][key])} | "
                             f"{_f(t['held_out'][key])} | {paper[key][0]} | {paper[key][1]} |")  # fmt: skip
            lines.append("")
            if name == "I" and grid.get("I_pnp"):
                p = grid["I_pnp"]
                lines += ["Table I measures the tool's marker along its ray from the camera at the "
                          "height the joints give it (what the servo loop measures). With the "
                          "marker's range as PnP solved it instead, after correction: "
                          f"Δd_max {_f(p['d_max'])}, σ_x {_f(p['sx'])}, σ_y {_f(p['sy'])}, "
                          f"σ_d {_f(p['sd'])} mm.", ""]  # fmt: skip
        lines += ["![grid errors](grid_errors.png)", ""]
    servo = results.get("servo")
    if servo:
        lines += [f"## Experiment 2: {servo['targets']} targets (Durovic 2017, Table III)", "",
                  f"Servoing succeeded on {servo['successes']} of {servo['targets']} (tolerance "
                  f"{servo.get('tolerance', 3.0):g} mm, corrected until within {servo.get('aim', 3.0):g} mm); distance between the tool "
                  f"and the target's centre in x-y, mm (mean {_f(servo['mean'])}).", "",
                  "| | here | Durovic 2017 |", "| --- | --- | --- |",
                  f"| Δd_max [mm] | {_f(servo['d_max'])} | {PAPER_TABLE_III['d_max']} |",
                  f"| σ_d [mm] | {_f(servo['sd'])} | {PAPER_TABLE_III['sd']} |", "",
                  *[f"- failed: {why}" for why in servo["failures"]], "",
                  "![servo distances](servo_histogram.png)", ""]  # fmt: skip
    val = results.get("validation")
    if val:
        lines += [f"## Model validation: {val['points']} poses (Showers 2016)", "",
                  "Distance between the forward kinematics and the measured tool position, mean ± sd, mm.", "",
                  "| | before fit | after fit | held out |", "| --- | --- | --- | --- |",
                  f"| here | {_f(val['before'][0])} ± {_f(val['before'][1])} | {_f(val['after'][0])} ± {_f(val['after'][1])} | "
                  f"{_f(val['held_out'][0])} ± {_f(val['held_out'][1])} |"]  # fmt: skip
        for label, b, a in PAPER_VALIDATION:
            lines.append(f"| Showers 2016, {label} | {b[0]} ± {b[1]} | {a[0]} ± {a[1]} | - |")
        lines += ["", f"Fitted: {val['params']}", ""]
        lines += [f"- not reached (the planner refused): {why}" for why in val.get("unreached", [])]
        lines += ["", "![model validation](validation.png)", ""]
    path = out / "report.md"
    path.write_text("\n".join(lines))
    return path


__all__ = [
    "ExperimentCommand",
    "corrected",
    "grid_tables",
    "servo_table",
    "statistics",
    "validation_table",
    "write_report",
]
