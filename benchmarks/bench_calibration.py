"""Kinematic calibration (Showers 2016, "Model Validation"): batched fit against a per-point loop.

Run: ``python benchmarks/bench_calibration.py [--n 200] [--repeat 5]``.

Both fits solve the same least-squares problem (tool offset, link lengths and
joint offsets of the Dobot V1.0 from ``n`` synthetic points) with the same
scipy solver; the baseline evaluates the forward kinematics one point at a
time, as a straightforward port of the report's per-point model would.
Times are CPU seconds of this process (``time.process_time``); the ratio is
measured in the same run. The recovered parameters are printed as well.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Mapping

import numpy as np

from armtree.maths.motion.kinematic_calibration import CalibrationPoints, fit_kinematics
from armtree.plugins.arms.dobot_v1.kinematics import DobotV1Model

NOMINAL = {"tool_offset_mm": 55.0, "l1_mm": 135.0, "l2_mm": 160.0}
FREE = ("tool_offset_mm", "l1_mm", "l2_mm")


class LoopModel:
    """A Dobot model whose ``position`` loops over points (a baseline, not a peer; no library peer is measured)."""

    def __init__(self, params: Mapping[str, float]) -> None:
        self.inner = DobotV1Model(**params)
        self.dof = 3

    def position(self, q: np.ndarray) -> np.ndarray:
        """Tool positions (N, 3) mm, one point per call."""
        return np.array([self.inner.position(row) for row in q])


def points(n: int, seed: int = 0) -> CalibrationPoints:
    """``n`` reachable poses of a perturbed Dobot with 0.2 mm measuring noise."""
    rng = np.random.default_rng(seed)
    truth = DobotV1Model(48.0, 0.0, 136.0, 159.0, (0.5, 1.5, -2.0))
    nominal = DobotV1Model()
    q = rng.uniform(nominal.lower, nominal.upper, (20 * n, 3))
    q = q[nominal.within_limits(q)][:n]
    return CalibrationPoints(q, truth.position(q) + rng.normal(0.0, 0.2, (n, 3)))


def timed(build, data: CalibrationPoints, repeat: int) -> tuple[float, object]:
    """Best CPU seconds of ``repeat`` fits, and the last fit."""
    best, fit = float("inf"), None
    for _ in range(repeat):
        start = time.process_time()
        fit = fit_kinematics(build, NOMINAL, data, free=FREE)
        best = min(best, time.process_time() - start)
    return best, fit


def main() -> None:
    """Print the batched and looped fit times, their ratio and the recovered parameters."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200, help="calibration points")
    parser.add_argument("--repeat", type=int, default=5, help="fits per variant (best counts)")
    args = parser.parse_args()
    data = points(args.n)
    batched, fit = timed(lambda p: DobotV1Model(**p), data, args.repeat)
    looped, _ = timed(LoopModel, data, max(1, args.repeat // 2))
    print(f"kinematic calibration, {args.n} points, free: {', '.join(FREE)} + joint offsets")
    print(f"  batched numpy residuals: {batched * 1e3:8.2f} ms CPU per fit")
    print(f"  per-point loop (baseline, not a peer): {looped * 1e3:8.2f} ms CPU per fit")
    print(f"  ratio (loop / batched):  {looped / batched:8.1f}x")
    print(
        "  recovered (truth 48 / 136 / 159 mm; 0.5, 1.5, -2.0 deg): "
        + ", ".join(f"{k} {fit.params[k]:.2f}" for k in FREE)
        + f"; offsets {np.round(fit.joint_offsets_deg, 2).tolist()} deg"
    )
    print(f"  RMS {fit.rms_before_mm:.2f} mm before, {fit.rms_after_mm:.3f} mm after")


if __name__ == "__main__":
    main()
