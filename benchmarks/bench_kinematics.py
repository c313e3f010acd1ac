"""Batched kinematics throughput of the arm models, against per-configuration Python loops.

Run: ``python benchmarks/bench_kinematics.py [--n 100000]``.

Each row of :data:`ENTRIES` is ``(name, make)``: ``make(n, rng)`` returns a
:class:`Case` holding a callable over ``n`` items and, optionally, a baseline
callable over a smaller sample of the same work, so adding an arm is one line
(the Magician, VICRA and DH arms also have ``bench_kinematics_dh.py`` with
roboticstoolbox as the baseline). Rates are items per CPU second of this
process (``time.process_time``; the machine is shared and all measured code is
single-threaded); the ratio compares rates measured in the same run.

Goal (issue 3): analytic Dobot IK >= 1,000,000 targets per second batched.
Anchor from the issue: a numpy batch of a 3-joint FK ~ 5.6 million per second.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from armtree.plugins.arms.dobot_v1.kinematics import DobotV1Model


@dataclass
class Case:
    """``run()`` does ``items`` units of work; ``baseline()`` does ``baseline_items`` of the same."""

    run: Callable[[], object]
    items: int
    baseline: Callable[[], object] | None = None
    baseline_items: int = 0
    baseline_name: str = ""


def best_rate(fn: Callable[[], object], items: int, repeat: int = 5) -> float:
    """Items per CPU second of the fastest of ``repeat`` calls."""
    best = math.inf
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
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
    """Dobot V1 tool positions (seed 004 eqs. 5-7), batched vs a math-module loop."""
    model, q = DobotV1Model(), _dobot_q(n, rng)
    small = q[: max(1, n // 10)]
    return Case(
        lambda: model.position(q), n, lambda: _dobot_fk_loop(small), len(small), "python loop"
    )


def dobot_fk_pose(n: int, rng: np.random.Generator) -> Case:
    """Dobot V1 4x4 tool poses, batched."""
    model, q = DobotV1Model(), _dobot_q(n, rng)
    small = q[: max(1, n // 10)]
    return Case(lambda: model.fk(q), n, lambda: _dobot_fk_loop(small), len(small), "python loop")


def dobot_link_frames(n: int, rng: np.random.Generator) -> Case:
    """Dobot V1 link frames (4 per configuration, for collision boxes), batched."""
    model, q = DobotV1Model(), _dobot_q(n, rng)
    return Case(lambda: model.link_frames(q), n)


def dobot_ik(n: int, rng: np.random.Generator) -> Case:
    """Dobot V1 analytic IK (seed 004 eqs. 8-10), both branches with limits, batched."""
    model = DobotV1Model()
    p = model.position(_dobot_q(n, rng))
    small = p[: max(1, n // 10)]
    return Case(
        lambda: model.ik_all(p), n, lambda: _dobot_ik_loop(small), len(small), "python loop"
    )


def dobot_jacobian(n: int, rng: np.random.Generator) -> Case:
    """Dobot V1 analytic Jacobian vs the base class's central differences."""
    from armtree.kinematics import KinematicModel

    model, q = DobotV1Model(), _dobot_q(n, rng)
    return Case(
        lambda: model.jacobian(q), n, lambda: KinematicModel.jacobian(model, q), n, "finite diff."
    )


#: The table: add ``(name, make)`` rows for other arms.
ENTRIES: list[tuple[str, Callable[[int, np.random.Generator], Case]]] = [
    ("dobot_v1 fk (position)", dobot_fk),
    ("dobot_v1 fk (4x4 pose)", dobot_fk_pose),
    ("dobot_v1 link frames", dobot_link_frames),
    ("dobot_v1 ik (analytic)", dobot_ik),
    ("dobot_v1 jacobian", dobot_jacobian),
]


def main() -> None:
    """Measure every entry and print a table of rates and ratios."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100_000, help="configurations per batch")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    table = Table(title=f"Batched kinematics, {args.n:,} configurations per call (CPU time)")
    for col in ("entry", "rate /s", "baseline", "baseline /s", "ratio"):
        table.add_column(col, justify="right" if col != "entry" and col != "baseline" else "left")
    with Progress(transient=True) as progress:
        task = progress.add_task("measuring", total=len(ENTRIES))
        for name, make in ENTRIES:
            case = make(args.n, rng)
            rate = best_rate(case.run, case.items, args.repeat)
            if case.baseline is not None:
                base = best_rate(case.baseline, case.baseline_items, args.repeat)
                table.add_row(
                    name, f"{rate:,.0f}", case.baseline_name, f"{base:,.0f}", f"{rate / base:,.1f}x"
                )
            else:
                table.add_row(name, f"{rate:,.0f}", "", "", "")
            progress.advance(task)
    Console().print(table)


if __name__ == "__main__":
    main()
