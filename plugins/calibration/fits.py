"""The fits behind ``fit_calibration``: hand-eye, linear correction, camera offset, kinematics.

Each takes ``visit_poses``' observations and returns a plain mapping: a one-line
``summary``, the profile ``sections`` to write into the calibration file, the
``record`` of what was measured, and what the residual plot draws. Corrections,
camera offsets and kinematic fits are cross-validated: the data is split into
folds, each fold's points are predicted by a fit of the others, and the held-out
error with the fit is compared with the held-out error without it; a fit that
makes it worse is refused (:class:`Refused`), as Showers 2016 suspected its own of
overfitting. Units: mm, degrees.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from armtree.api.rig import Camera, Rig
from armtree.config.calibration import correction_mapping, update_calibration_file
from armtree.maths.motion.kinematic_calibration import CalibrationPoints, fit_kinematics
from armtree.maths.perception.frames import (
    EYE_IN_HAND,
    LinearCorrection,
    along_ray_to_height,
    estimate_camera_offset,
    tool_to_marker,
)
from armtree.maths.perception.hand_eye import DegenerateData, MarkerView, solve


class Refused(ValueError):
    """The observations cannot calibrate, or the fit would make things worse; says why."""


def fit(
    kind: str, observations: dict[str, Any], rig: Rig, methods: Sequence[str], folds: int
) -> dict[str, Any]:
    """Dispatch to the fit of ``kind``; :class:`Refused` with the reason."""
    poses = observations.get("poses") or []
    if not poses:
        raise Refused("no observations: visit_poses measured nothing")
    try:
        if kind == "hand_eye":
            result = hand_eye(poses, rig, methods)
        elif kind == "correction":
            result = correction(poses, rig, folds)
        elif kind == "camera_offset":
            result = camera_offset(poses, observations.get("touched"), rig)
        else:
            result = kinematics(poses, rig, folds)
    except DegenerateData as exc:
        raise Refused(str(exc)) from None
    return _with_slips(result, observations.get("slips"))


def _with_slips(result: dict[str, Any], slips: dict[str, Any] | None) -> dict[str, Any]:
    """``result`` saying what the watch for missed steps found while the poses were visited."""
    if not slips:
        return result
    result["summary"] += (
        f"; missed steps: in {slips['checks']} looks the camera found the arm moved "
        f"{_times(slips['found'])}; it homed {_times(slips['homings'])} and measured "
        f"{slips['redone']} poses again"
    )
    keys = ("checks", "found", "homings", "redone")
    result["record"][1]["missed_steps"] = {k: slips[k] for k in keys}
    return result


def _times(n: int) -> str:
    return "once" if n == 1 else f"{n} times"


def folds_of(n: int, k: int, seed: int = 0) -> list[np.ndarray]:
    """``k`` (at most ``n``) disjoint index sets covering ``range(n)``, shuffled with ``seed``."""
    order = np.random.default_rng(seed).permutation(n)
    return [f for f in np.array_split(order, min(k, n)) if len(f)]


def _reached(poses: list[dict[str, Any]]) -> list[dict[str, Any]]:
    missed = [p for p in poses if not p.get("reached", True)]
    if missed:
        raise Refused(
            f"the arm did not reach the pose {missed[0]['commanded']} mm: {missed[0].get('why', '')}"
        )
    return poses


# -------------------------------------------------------------------- hand-eye


def _camera(rig: Rig, what: str) -> Camera:
    """The rig's camera; :class:`Refused` when it has none (``what`` needs one)."""
    if rig.camera is None:
        raise Refused(f"{what} needs the rig's camera; this rig has none")
    return rig.camera


def hand_eye(poses: list[dict[str, Any]], rig: Rig, methods: Sequence[str]) -> dict[str, Any]:
    """Durovic 2017's three positions, or every method on N poses; the least residual wins."""
    poses = _reached(poses)
    views = [
        MarkerView(np.array(p["tool_pose"]), np.array(p["tvec"]) if p.get("seen") else None,
                   np.array(p["rvec"]) if p.get("seen") else None)
        for p in poses
    ]  # fmt: skip
    camera = _camera(rig, "a hand-eye calibration")
    mount = camera.mount
    marker = getattr(_workcell(rig).tool_marker, "offset_mm", (0.0, 0.0, 0.0))
    if len(poses) == 3 and not methods:
        methods = ["three_positions"]
    table = _workcell(rig).table_z_mm
    found = solve(
        views,
        mount,
        methods=list(methods) or None,
        marker_offset=marker,
        guess=np.asarray(camera.extrinsics, dtype=float),
        marker_z=None if table is None else float(table),
    )
    best = found[0]
    # solve puts first a fit with a pose (a finite residual), or raises DegenerateData
    assert best.pose is not None
    frame = "tool" if mount == EYE_IN_HAND else "base"
    pose = np.round(best.pose, 6).tolist()
    before = np.asarray(camera.extrinsics, dtype=float)
    moved = float(np.linalg.norm(best.pose[:3, 3] - before[:3, 3]))
    table_rows = [
        {"method": f.method, "rms_mm": None if f.rms_mm == float("inf") else round(f.rms_mm, 3),
         "max_mm": None if f.rms_mm == float("inf") else round(f.max_mm, 3), "note": f.degenerate}
        for f in found
    ]  # fmt: skip
    return {
        "kind": "hand_eye",
        "summary": (
            f"{best.method}: RMS residual {best.rms_mm:.2f} mm (max {best.max_mm:.2f}) over "
            f"{len(best.residuals_mm)} views; camera moved {moved:.1f} mm from the profile's pose"
        ),
        "sections": {"camera": {"extrinsics": pose}},
        "record": (
            "hand_eye",
            {
                "method": best.method,
                "mount": mount,
                "frame": frame,
                "views": len(poses),
                "residual_rms_mm": round(best.rms_mm, 3),
                "residual_max_mm": round(best.max_mm, 3),
                "methods": table_rows,
            },
        ),  # fmt: skip
        "plot": {
            "title": f"hand-eye calibration ({best.method})",
            "bars": {"residual (mm)": np.round(best.residuals_mm, 3).tolist()},
            "methods": table_rows,
        },  # fmt: skip
    }


def _workcell(rig: Rig) -> Any:
    from armtree.config.workcell import workcell_of

    return workcell_of(getattr(rig, "profile", None))


# -------------------------------------------------------------------- correction (eq. 8)


def vision_tool_positions(
    poses: list[dict[str, Any]], rig: Rig, along_ray: bool = True
) -> np.ndarray:
    """The tool centre as the fixed camera measures it (mm), less the marker's offset turned
    with the tool; NaN where unseen.

    With ``along_ray`` the marker is put where its ray from the camera meets the height
    the joints give it, as the servo loop measures it: the marker's direction is what
    vision measures best, its distance worst (Durovic 2017's conclusion; from 480 mm a
    25 mm marker's range is off by millimetres). Without, its pose as the camera
    solved it (PnP through the camera's believed pose).
    """
    marker = np.asarray(getattr(_workcell(rig).tool_marker, "offset_mm", (0.0, 0.0, 0.0)))
    out = []
    for p in poses:
        if not p.get("seen"):
            out.append(np.full(3, np.nan))
            continue
        camera = np.array(p["camera"])
        seen = (camera @ np.append(p["tvec"], 1.0))[:3]
        tool = np.array(p["tool_pose"])
        lift = tool[:3, :3] @ marker
        if along_ray:
            seen = along_ray_to_height(camera[:3, 3], seen, tool[2, 3] + lift[2])
        out.append(seen - lift)
    return np.array(out)


def cross_validated(
    measured: np.ndarray, truth: np.ndarray, folds: int
) -> tuple[np.ndarray, np.ndarray]:
    """Held-out x-y errors (mm, per point) without and with Durovic 2017's eq. 8 fitted on the
    other folds."""
    before = np.linalg.norm(measured[:, :2] - truth[:, :2], axis=1)
    after = np.empty(len(measured))
    for fold in folds_of(len(measured), folds):
        train = np.setdiff1d(np.arange(len(measured)), fold)
        corr = LinearCorrection.fit(measured[train], truth[train])
        after[fold] = np.linalg.norm(corr.apply(measured[fold])[:, :2] - truth[fold, :2], axis=1)
    return before, after


def correction(poses: list[dict[str, Any]], rig: Rig, folds: int) -> dict[str, Any]:
    """Durovic 2017, eq. 8 for what vision measures and for where the arm goes."""
    poses = _reached(poses)
    truth = np.array([p["truth"] for p in poses if p.get("truth") is not None])
    if len(truth) != len(poses):
        raise Refused("the measuring device measured no truth at some poses (measure_tool)")
    commanded = np.array([p["commanded"] for p in poses])
    sections: dict[str, Any] = {}
    record: dict[str, Any] = {"points": len(poses), "folds": folds}
    lines, bars = [], {}
    sets = [("arm_correction", commanded, truth)]
    vision = vision_tool_positions(poses, rig)
    seen = np.all(np.isfinite(vision), axis=1)
    if rig.camera is not None and rig.camera.mount != EYE_IN_HAND and _workcell(rig).tool_marker:
        if seen.sum() < 4:
            unseen = [poses[i]["commanded"] for i in np.flatnonzero(~seen)[:1]]
            raise Refused(f"the camera saw the tool's marker at {int(seen.sum())} of {len(poses)} points; "
                          f"at least 4 needed (first unseen: {unseen} mm)")  # fmt: skip
        sets.insert(0, ("vision_correction", vision[seen], truth[seen]))
    for name, measured, true in sets:
        if len(measured) < 4 or np.ptp(measured[:, 0]) < 1.0 or np.ptp(measured[:, 1]) < 1.0:
            raise Refused(f"{name}: the points do not spread along both x and y")
        before, after = cross_validated(measured, true, folds)
        entry: dict[str, Any] = {
            "held_out_before_mm": round(float(np.mean(before)), 3),
            "held_out_after_mm": round(float(np.mean(after)), 3),
        }
        if np.mean(after) >= np.mean(before):
            entry["refused"] = "the fit makes the held-out error worse"
            lines.append(
                f"{name}: refused (held-out {np.mean(before):.2f} -> {np.mean(after):.2f} mm)"
            )
        else:
            corr = LinearCorrection.fit(measured, true)
            sections.setdefault("calibration", {})[name] = correction_mapping(corr)
            entry.update(correction_mapping(corr))
            lines.append(f"{name}: held-out {np.mean(before):.2f} -> {np.mean(after):.2f} mm")
        record[name] = entry
        bars[f"{name} before"] = np.round(before, 3).tolist()
        bars[f"{name} held out"] = np.round(after, 3).tolist()
    if not sections:
        raise Refused("every correction makes the held-out error worse: " + "; ".join(lines))
    return {"kind": "correction", "summary": "; ".join(lines), "sections": sections,
            "record": ("correction", record), "plot": {"title": "linear correction (Durovic 2017, eq. 8)", "bars": bars}}  # fmt: skip


# -------------------------------------------------------------------- camera offset (eq. 17)


def camera_offset(poses: list[dict[str, Any]], touched: Any, rig: Rig) -> dict[str, Any]:
    """Showers 2016, eq. 17: P_CT from touch tests, leave-one-out; refused when it predicts the
    touched marker worse than the profile's offset does."""
    poses = [p for p in _reached(poses) if p.get("seen")]
    if touched is None:
        raise Refused("no touch measurement of the marker (visit_poses touch:)")
    if len(poses) < 3:
        raise Refused(f"the camera saw the marker from {len(poses)} poses; at least 3 needed")
    extr = np.asarray(_camera(rig, "the camera offset").extrinsics, dtype=float)
    r_tc = extr[:3, :3]
    p_ca = [np.array(p["tvec"]) for p in poses]
    tools = [np.array(p["tool_pose"]) for p in poses]
    p0a = np.asarray(touched, dtype=float)

    def predict(p_ct: np.ndarray, i: int) -> np.ndarray:
        tool_T_camera = np.eye(4)
        tool_T_camera[:3, :3], tool_T_camera[:3, 3] = r_tc, -r_tc @ p_ct
        return tools[i][:3, 3] + tool_to_marker(tools[i], tool_T_camera, p_ca[i])  # eq. 18

    current = -r_tc.T @ extr[:3, 3]
    before = np.array([np.linalg.norm(predict(current, i) - p0a) for i in range(len(poses))])
    after = np.empty(len(poses))
    for i in range(len(poses)):
        rest = [j for j in range(len(poses)) if j != i]
        p_ct = estimate_camera_offset(
            [p_ca[j] for j in rest], [tools[j] for j in rest], [p0a] * len(rest), r_tc
        )
        after[i] = np.linalg.norm(predict(p_ct, i) - p0a)
    if np.mean(after) >= np.mean(before):
        raise Refused(
            f"the fitted camera offset predicts the touched marker worse held out "
            f"({np.mean(before):.2f} -> {np.mean(after):.2f} mm): the profile's offset stays"
        )
    p_ct = estimate_camera_offset(p_ca, tools, [p0a] * len(poses), r_tc)  # eq. 17, averaged
    new = extr.copy()
    new[:3, 3] = -r_tc @ p_ct
    return {
        "kind": "camera_offset",
        "summary": f"P_CT {np.round(p_ct, 2).tolist()} mm; held-out {np.mean(before):.2f} -> {np.mean(after):.2f} mm",
        "sections": {"camera": {"extrinsics": np.round(new, 6).tolist()}},
        "record": (
            "camera_offset",
            {
                "p_ct_mm": np.round(p_ct, 3).tolist(),
                "views": len(poses),
                "held_out_before_mm": round(float(np.mean(before)), 3),
                "held_out_after_mm": round(float(np.mean(after)), 3),
            },
        ),  # fmt: skip
        "plot": _held_out_plot(
            "camera offset from touch tests (Showers 2016, eq. 17)",
            "profile's offset",
            before,
            after,
        ),
    }


# -------------------------------------------------------------------- kinematics


def arm_model_builder(rig: Rig) -> tuple[Any, dict[str, Any], Any]:
    """The arm factory's model builder, its profile keys, and the factory (for its PARAMS)."""
    profile = rig.profile
    config = profile.component("arm")
    if config is None:
        raise Refused("the profile has no arm: there is no kinematic model to calibrate")
    arm = dict(config)
    component = profile.registry.get("arm", arm["type"])
    make = getattr(component.factory, "model", None)
    if make is None:
        raise Refused(f"the {arm['type']} arm offers no kinematic model to calibrate")
    return make, arm, component


def kinematic_cv(
    points: CalibrationPoints, make: Any, arm: dict[str, Any], free: tuple[str, ...], folds: int
) -> dict[str, np.ndarray]:
    """Held-out distances (mm per point) with the profile's model and with a fit of the others."""
    initial = {k: float(arm[k]) for k in free}
    before = np.linalg.norm(make(arm).position(points.joints_deg) - points.measured_mm, axis=1)
    after = np.empty(len(before))
    for fold in folds_of(len(before), folds):
        train = np.setdiff1d(np.arange(len(before)), fold)
        f = fit_kinematics(lambda p: make({**arm, **p}), initial,
                           CalibrationPoints(points.joints_deg[train], points.measured_mm[train]), free=free)  # fmt: skip
        after[fold] = np.linalg.norm(
            f.positions(points.joints_deg[fold]) - points.measured_mm[fold], axis=1
        )
    return {"before": before, "after": after}


def kinematics(poses: list[dict[str, Any]], rig: Rig, folds: int) -> dict[str, Any]:
    """Showers 2016's model validation: tool offset and joint offsets by least squares."""
    poses = _reached(poses)
    make, arm, component = arm_model_builder(rig)
    names = {p.name for p in component.params}
    if "joint_offsets_deg" not in names:
        raise Refused(
            f"the {arm['type']} arm takes no joint_offsets_deg: there is nothing to write"
        )
    free = tuple(k for k in ("tool_offset_mm",) if k in names)
    joints = np.array([p["joints"] for p in poses])
    truth = np.array([p["truth"] for p in poses])
    points = CalibrationPoints(joints, truth, "measuring device")
    cv = kinematic_cv(points, make, arm, free, folds)
    if np.mean(cv["after"]) >= np.mean(cv["before"]):
        raise Refused(f"the kinematic fit makes the held-out error worse ({np.mean(cv['before']):.2f} -> "
                      f"{np.mean(cv['after']):.2f} mm): the profile's model stays")  # fmt: skip
    f = fit_kinematics(
        lambda p: make({**arm, **p}), {k: float(arm[k]) for k in free}, points, free=free
    )
    section: dict[str, Any] = {k: round(f.params[k], 4) for k in free}
    section["joint_offsets_deg"] = [round(float(v), 4) for v in f.joint_offsets_deg]
    b, a = cv["before"], cv["after"]
    return {
        "kind": "kinematics",
        "summary": f"held-out mean distance {b.mean():.2f} ± {b.std(ddof=1):.2f} -> {a.mean():.2f} ± {a.std(ddof=1):.2f} mm",
        "sections": {"arm": section},
        "record": (
            "kinematics",
            {
                "points": len(poses),
                "folds": folds,
                **section,
                "held_out_before_mm": [round(b.mean(), 3), round(b.std(ddof=1), 3)],
                "held_out_after_mm": [round(a.mean(), 3), round(a.std(ddof=1), 3)],
            },
        ),  # fmt: skip
        "plot": _held_out_plot(
            "kinematic calibration (Showers 2016, model validation)", "profile's model", b, a
        ),
    }


def _held_out_plot(title: str, profile: str, before: np.ndarray, after: np.ndarray) -> dict:
    """What the residual plot draws for a cross-validated fit: the held-out errors (mm) with
    the profile's values (``profile`` names them) and with the fit."""
    bars = {profile: np.round(before, 3).tolist(), "held out": np.round(after, 3).tolist()}
    return {"title": title, "bars": bars}


# -------------------------------------------------------------------- writing


def write(result: dict[str, Any], path: str, plot: str | None) -> None:
    """Merge the fit into the calibration file and draw its residual plot."""
    name, record = result["record"]
    update_calibration_file(path, result["sections"], (name, record))
    if plot:
        draw(result["plot"], plot)


def draw(spec: dict[str, Any], path: str) -> None:
    """A PNG of per-point residual bars, one group per series (mm)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bars = spec.get("bars") or {}
    fig, ax = plt.subplots(figsize=(10, 4.5))
    width = 0.8 / max(1, len(bars))
    for k, (label, values) in enumerate(bars.items()):
        values = np.asarray(values, dtype=float)
        ax.bar(
            np.arange(len(values)) + k * width,
            values,
            width,
            label=f"{label} (mean {np.nanmean(values):.2f} mm)",
        )
    ax.set_xlabel("pose")
    ax.set_ylabel("residual (mm)")
    ax.set_title(spec.get("title", "calibration"))
    ax.legend()
    rows = spec.get("methods")
    if rows:
        text = "\n".join(
            f"{r['method']}: {r['rms_mm'] if r['rms_mm'] is not None else '-'} mm {r['note'][:40]}"
            for r in rows
        )
        ax.text(1.01, 1.0, text, transform=ax.transAxes, va="top", fontsize=7, family="monospace")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


__all__ = ["Refused", "camera_offset", "correction", "cross_validated", "draw", "fit", "folds_of",
           "hand_eye", "kinematics", "vision_tool_positions", "write"]  # fmt: skip
