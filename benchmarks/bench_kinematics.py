"""Batched kinematics throughput of the arm models, against loops, finite differences and rtb.

Run: ``python benchmarks/bench_kinematics.py [--n 100000]``.

The Dobot V1 rows come from :data:`ENTRIES`: each ``(arm, what, make)`` row's
``make(n, rng)`` returns a :class:`Case` holding a callable over ``n`` items
and, optionally, a baseline callable over a smaller sample of the same work,
so adding an arm is one line. The Magician, VICRA and DH rows
(:func:`analytic_rows`, :func:`dh_rows`, :func:`motoman_rows`) compare DH FK
and IK with roboticstoolbox-python, which comes with ``pip install -e
'.[bench]'``; without it those rows are measured without a peer and say so. Every rtb ratio is measured in the same
run on the same DH model (rtb's Puma 560, standard DH, and the slides'
modified-DH PUMA built both ways), on the same configurations and targets.

Rates are items per CPU second of this process (``time.process_time``; the
machine is shared and all measured code is single-threaded); every ratio
compares rates measured in the same run.

Goals (issue 3): analytic Dobot IK >= 1,000,000 targets per second batched
(anchor from the issue: a numpy batch of a 3-joint FK ~ 5.6 million per
second); DH FK >= 1,000,000 configurations/s batched and >= 50x rtb; DH IK >= 4x
rtb's ikine_LM at the same tolerance and success rate; analytic Magician / VICRA
IK >= 1,000,000 per second batched.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from armtree.plugins.arms.dh.kinematics import DHModel, DHRow
from armtree.plugins.arms.dobot_magician.kinematics import MagicianModel
from armtree.plugins.arms.dobot_v1.kinematics import DobotV1Model
from armtree.plugins.arms.vicra.kinematics import VicraModel


@dataclass
class Row:
    """One measured figure: ``rate`` items per second (and the baseline's, if any)."""

    arm: str
    what: str
    rate: float
    baseline: str = ""
    baseline_rate: float = float("nan")
    note: str = ""

    @property
    def ratio(self) -> float:
        """How many times faster than the baseline."""
        return self.rate / self.baseline_rate


@dataclass
class Case:
    """``run()`` does ``items`` units of work; ``baseline()`` does ``baseline_items`` of the same."""

    run: Callable[[], object]
    items: int
    baseline: Callable[[], object] | None = None
    baseline_items: int = 0
    baseline_name: str = ""


def clock() -> float:
    """Process CPU time: the machine is shared, and every measured call runs on one thread."""
    return time.process_time()


def best_rate(fn: Callable[[], object], items: int, repeat: int = 5) -> float:
    """Items per CPU second of the fastest of ``repeat`` calls."""
    best = math.inf
    for _ in range(repeat):
        t0 = clock()
        fn()
        best = min(best, clock() - t0)
    return items / max(best, 1e-9)


# ---------------------------------------------------------------- Dobot V1.0


def _dobot_q(n: int, rng: np.random.Generator) -> np.ndarray:
    q1 = rng.uniform(0, 25, n)
    return np.stack([rng.uniform(-135, 135, n), q1, rng.uniform(q1 + 35, 60)], axis=-1)


def _dobot_fk_loop(q: np.ndarray, d: float = 55.0) -> list[tuple[float, float, float]]:
    out = []
    for q0, q1, q2 in q.tolist():
        t0, t1, t2 = math.radians(q0), math.radians(q1), math.radians(q2)
        r = 135.0 * math.sin(t1) + 160.0 * math.cos(t2) + d
        out.append(
            (math.cos(t0) * r, math.sin(t0) * r, 135.0 * math.cos(t1) - 160.0 * math.sin(t2))
        )
    return out


def _dobot_ik_loop(p: np.ndarray, d: float = 55.0) -> list[tuple[float, float, float]]:
    out = []
    l1, l2 = 135.0, 160.0
    for x, y, z in p.tolist():
        r = math.hypot(x, y)
        rho = math.hypot(r - d, z)
        alpha = math.acos((l1 * l1 + rho * rho - l2 * l2) / (2 * l1 * rho))
        gamma = math.acos((l1 * l1 + l2 * l2 - rho * rho) / (2 * l1 * l2))
        phi = math.atan2(z, r - d)
        out.append(
            (
                math.degrees(math.atan2(y, x)),
                math.degrees(math.pi / 2 - phi - alpha),
                math.degrees(math.pi - phi - alpha - gamma),
            )
        )
    return out


def dobot_fk(n: int, rng: np.random.Generator) -> Case:
    """Dobot V1 tool positions (Showers 2016 eqs. 5-7), batched vs a math-module loop."""
    model, q = DobotV1Model(), _dobot_q(n, rng)
    small = q[: max(1, n // 10)]
    return Case(
        lambda: model.position(q),
        n,
        lambda: _dobot_fk_loop(small),
        len(small),
        "python loop (baseline, not a peer)",
    )


def dobot_fk_pose(n: int, rng: np.random.Generator) -> Case:
    """Dobot V1 4x4 tool poses, batched."""
    model, q = DobotV1Model(), _dobot_q(n, rng)
    small = q[: max(1, n // 10)]
    return Case(
        lambda: model.fk(q),
        n,
        lambda: _dobot_fk_loop(small),
        len(small),
        "python loop (baseline, not a peer)",
    )


def dobot_link_frames(n: int, rng: np.random.Generator) -> Case:
    """Dobot V1 link frames (4 per configuration, for collision boxes), batched."""
    model, q = DobotV1Model(), _dobot_q(n, rng)
    return Case(lambda: model.link_frames(q), n)


def dobot_ik(n: int, rng: np.random.Generator) -> Case:
    """Dobot V1 analytic IK (Showers 2016 eqs. 8-10), both branches with limits, batched."""
    model = DobotV1Model()
    p = model.position(_dobot_q(n, rng))
    small = p[: max(1, n // 10)]
    return Case(
        lambda: model.ik_all(p),
        n,
        lambda: _dobot_ik_loop(small),
        len(small),
        "python loop (baseline, not a peer)",
    )


def dobot_jacobian(n: int, rng: np.random.Generator) -> Case:
    """Dobot V1 analytic Jacobian vs the base class's central differences."""
    from armtree.maths.motion.kinematics import KinematicModel

    model, q = DobotV1Model(), _dobot_q(n, rng)
    return Case(
        lambda: model.jacobian(q),
        n,
        lambda: KinematicModel.jacobian(model, q),
        n,
        "finite diff. (baseline, not a peer)",
    )


#: The Dobot V1 table: add ``(arm, what, make)`` rows for other arms.
ENTRIES: list[tuple[str, str, Callable[[int, np.random.Generator], Case]]] = [
    ("dobot_v1", "fk (position)", dobot_fk),
    ("dobot_v1", "fk (4x4 pose)", dobot_fk_pose),
    ("dobot_v1", "link frames", dobot_link_frames),
    ("dobot_v1", "ik (analytic)", dobot_ik),
    ("dobot_v1", "jacobian", dobot_jacobian),
]


def entry_rows(n: int, repeat: int, progress: Progress) -> list[Row]:
    """Every :data:`ENTRIES` row measured on ``n`` items, with its baseline where it has one."""
    rng = np.random.default_rng(0)
    rows = []
    task = progress.add_task("dobot_v1", total=len(ENTRIES))
    for arm, what, make in ENTRIES:
        case = make(n, rng)
        rate = best_rate(case.run, case.items, repeat)
        row = Row(arm, what, rate)
        if case.baseline is not None:
            row.baseline = case.baseline_name
            row.baseline_rate = best_rate(case.baseline, case.baseline_items, repeat)
        rows.append(row)
        progress.advance(task)
    return rows


# ---------------------------------------------------------------- Magician, VICRA, DH


def analytic_rows(n: int) -> list[Row]:
    """FK and IK of the closed-form arms on ``n`` random configurations each."""
    rows = []
    rng = np.random.default_rng(0)
    for model in (MagicianModel(), VicraModel()):
        q = rng.uniform(model.lower, model.upper, size=(n, model.dof))
        p = model.position(q)
        rows.append(Row(model.name, "FK position", best_rate(partial(model.position, q), n)))
        rows.append(Row(model.name, "FK 4x4 pose", best_rate(partial(model.fk, q), n, 3)))
        rows.append(Row(model.name, "IK all branches", best_rate(partial(model.ik_all, p), n)))
    return rows


def puma_standard() -> DHModel:
    """rtb's Puma 560 (standard DH, its joint limits), in mm."""
    rows = [
        DHRow(0.0, 90.0, 671.83),
        DHRow(431.8, 0.0, 0.0),
        DHRow(20.3, -90.0, 150.05),
        DHRow(0.0, 90.0, 431.8),
        DHRow(0.0, -90.0, 0.0),
        DHRow(0.0, 0.0, 0.0),
    ]
    limits = [(-160, 160), (-45, 225), (-225, 45), (-110, 170), (-100, 100), (-266, 266)]
    return DHModel(rows, limits, "standard", name="puma560")


def puma_modified() -> DHModel:
    """The slides' PUMA 560 (Aceves slides, modified DH), +-180 degrees per joint, in mm."""
    rows = [
        DHRow(0.0, 0.0, 0.0),
        DHRow(0.0, -90.0, 0.0),
        DHRow(431.0, 0.0, 149.0),
        DHRow(20.0, -90.0, 433.0),
        DHRow(0.0, 90.0, 0.0),
        DHRow(0.0, -90.0, 0.0),
    ]
    return DHModel(rows, [(-180, 180)] * 6, "modified", name="puma560_mdh")


def rtb_robot(model: DHModel):
    """The same arm as a roboticstoolbox DHRobot (metres, radians)."""
    import roboticstoolbox as rtb

    links = []
    for row, joint in zip(model.rows, model.joints, strict=True):
        cls = rtb.RevoluteMDH if model.convention == "modified" else rtb.RevoluteDH
        links.append(
            cls(
                a=row.a / 1000.0,
                alpha=np.radians(row.alpha),
                d=row.d / 1000.0,
                offset=np.radians(row.theta),
                qlim=np.radians([joint.lower, joint.upper]),
            )
        )
    return rtb.DHRobot(links, name=model.name)


def pose_errors(
    model: DHModel, q: np.ndarray, targets: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Position (mm) and orientation (rad) errors of ``fk(q)`` against ``targets``; inf for NaN."""
    ok = np.all(np.isfinite(q), axis=-1)
    pos = np.full(len(q), np.inf)
    rot = np.full(len(q), np.inf)
    if ok.any():
        T = model.fk(q[ok])
        pos[ok] = np.linalg.norm(T[:, :3, 3] - targets[ok, :3, 3], axis=-1)
        R = np.swapaxes(T[:, :3, :3], 1, 2) @ targets[ok, :3, :3]
        rot[ok] = np.arccos(np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1, 1))
    return pos, rot


def dh_rows(n: int, n_rtb_fk: int, n_ik: int, n_ik_ours: int, progress: Progress) -> list[Row]:
    """DH FK and IK, ours against roboticstoolbox on the same models and inputs."""
    try:
        import roboticstoolbox  # noqa: F401
    except ImportError:
        roboticstoolbox = None
    rows = []
    rng = np.random.default_rng(1)
    for model in (puma_standard(), puma_modified()):
        task = progress.add_task(f"{model.name}", total=4)
        q = rng.uniform(model.lower, model.upper, size=(n, model.dof))
        ours_fk = best_rate(partial(model.fk, q), n, 3)
        ours_pos = best_rate(partial(model.position, q), n, 3)
        progress.advance(task)
        # IK targets: poses of random configurations away from the joint limits; ours solves
        # the whole batch, rtb the first n_ik of the same targets, one call each
        inner = 0.1 * (model.upper - model.lower)
        q_ik = rng.uniform(model.lower + inner, model.upper - inner, (n_ik_ours, model.dof))
        targets = model.fk(q_ik)
        tol_mm, tol_rad = 0.01, 1e-4
        t0 = clock()
        ours = model.ik_batch(targets, tol=tol_mm * 0.1)
        ours_ik = n_ik_ours / (clock() - t0)
        pe, re = pose_errors(model, ours, targets)
        good = (pe < tol_mm) & (re < tol_rad)
        ours_ok, ours_ok_all = float(np.mean(good[:n_ik])), float(np.mean(good))
        targets = targets[:n_ik]
        progress.advance(task)
        if roboticstoolbox is None:
            rows.append(Row(model.name, "FK 4x4 pose", ours_fk, note="rtb not installed"))
            rows.append(Row(model.name, "FK position", ours_pos))
            rows.append(
                Row(model.name, "IK (DLS, 6-D pose)", ours_ik, note=f"success {ours_ok_all:.2%}")
            )
            progress.advance(task, 2)
            continue
        from spatialmath import SE3

        robot = rtb_robot(model)
        qs = np.radians(q[:n_rtb_fk])
        t0 = clock()
        T_rtb = robot.fkine(qs)
        rtb_fk = n_rtb_fk / (clock() - t0)
        t0 = clock()
        for k in range(200):
            robot.fkine(qs[k])
        rtb_single = 200 / (clock() - t0)
        diff = np.abs(np.array(T_rtb.A)[:, :3, 3] * 1000.0 - model.fk(q[:n_rtb_fk])[:, :3, 3]).max()
        progress.advance(task)
        rtb_q = np.full((n_ik, model.dof), np.nan)
        # rtb's LM stops when E = 0.5 e'e < tol, e in m and rad: 5e-11 is |e| < 10 um (1e-5 rad),
        # looser than ours (|e| < 1 um with 200 mm per rad); both are judged by the same check
        tol_rtb = 5e-11
        metres = targets.copy()
        metres[:, :3, 3] /= 1000.0
        t0 = clock()
        for k in range(n_ik):
            sol = robot.ikine_LM(SE3(metres[k], check=False), tol=tol_rtb)
            if sol.success:
                rtb_q[k] = np.degrees(sol.q)
        rtb_ik = n_ik / (clock() - t0)
        pe, re = pose_errors(model, rtb_q, targets)
        rtb_ok = float(np.mean((pe < tol_mm) & (re < tol_rad)))
        progress.advance(task)
        rows.append(
            Row(
                model.name,
                "FK 4x4 pose",
                ours_fk,
                "rtb fkine, batch",
                rtb_fk,
                f"max |dp| {diff:.1e} mm; rtb single call {rtb_single:,.0f}/s",
            )
        )
        rows.append(Row(model.name, "FK position", ours_pos, "rtb fkine, batch", rtb_fk))
        rows.append(
            Row(
                model.name,
                "IK (DLS, 6-D pose)",
                ours_ik,
                "rtb ikine_LM",
                rtb_ik,
                f"success on the same {n_ik}: ours {ours_ok:.1%}, rtb {rtb_ok:.1%} (< {tol_mm} mm,"
                f" < {tol_rad} rad); ours on all {n_ik_ours:,}: {ours_ok_all:.2%}",
            )
        )
    return rows


def motoman_rows(n: int, n_ik: int) -> list[Row]:
    """The shipped 5-joint Motoman L-3 profile: FK, and IK of tool positions (3 constraints)."""
    from armtree.loader.profile import load_profile
    from armtree.plugins.arms.dh.plugin import dh_factory

    model = dh_factory.model(load_profile("dh_motoman_l3").component("arm"))
    rng = np.random.default_rng(2)
    q = rng.uniform(model.lower, model.upper, size=(n, model.dof))
    p = model.position(q[:n_ik])
    t0 = clock()
    sols = model.ik_batch(p, tol=1e-3)
    rate = n_ik / (clock() - t0)
    ok = np.all(np.isfinite(sols), axis=-1)
    err = np.linalg.norm(model.position(sols[ok]) - p[ok], axis=-1)
    return [
        Row("motoman_l3", "FK 4x4 pose", best_rate(partial(model.fk, q), n, 3)),
        Row(
            "motoman_l3",
            "IK (DLS, position)",
            rate,
            note=f"success {ok.mean():.2%}, max error {err.max():.1e} mm",
        ),
    ]


def rows(
    n: int = 100_000,
    n_rtb_fk: int = 2_000,
    n_ik: int = 300,
    n_ik_ours: int = 20_000,
    repeat: int = 5,
) -> list[Row]:
    """Every figure of this benchmark, in table order."""
    with Progress(transient=True) as progress:
        return (
            entry_rows(n, repeat, progress)
            + analytic_rows(n)
            + dh_rows(n, n_rtb_fk, n_ik, max(n_ik, n_ik_ours), progress)
            + motoman_rows(n, n_ik_ours)
        )


def main() -> None:
    """Measure every row and print a table of rates and ratios."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100_000, help="configurations per FK/IK batch")
    parser.add_argument("--repeat", type=int, default=5, help="calls per Dobot V1 figure (best)")
    parser.add_argument("--n-ik", type=int, default=300, help="IK targets compared with rtb")
    parser.add_argument("--n-ik-ours", type=int, default=20_000, help="IK batch size for armtree")
    args = parser.parse_args()
    table = Table(title=f"Batched kinematics, {args.n:,} configurations per call (CPU time)")
    for col in ("arm", "what", "armtree /s", "peer or baseline", "its /s", "ratio", "note"):
        table.add_column(col, justify="right" if col.endswith("/s") or col == "ratio" else "left")
    measured = rows(args.n, n_ik=args.n_ik, n_ik_ours=args.n_ik_ours, repeat=args.repeat)
    for r in measured:
        has_base = np.isfinite(r.baseline_rate)
        table.add_row(
            r.arm,
            r.what,
            f"{r.rate:,.0f}",
            r.baseline,
            f"{r.baseline_rate:,.0f}" if has_base else "",
            f"{r.ratio:,.1f}x" if has_base else "",
            r.note,
        )
    Console(width=200).print(table)


if __name__ == "__main__":
    main()
