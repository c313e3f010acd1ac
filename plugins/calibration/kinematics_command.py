"""``armtree calibrate kinematics``: least-squares arm calibration (Showers 2016, "Model Validation").

The report recorded joint angles with the tool tip on known graph-paper points
(Fig. 6) and fitted the tool offset ``d``, angle offsets and scale factors
(link lengths held fixed) so the forward kinematics (eqs. 5-7) match. Here the
points come from a CSV/YAML file (``--points``), or from the simulation
(``--simulate N``): the sim profile's arm is driven through its driver to N
random poses and the tool is measured by a *simulated measuring device*, the
simulator's true tool position (the emulator's true joints, with missed-step
faults injected so the reported joints are off, through the arm model with any
``--sim-set`` changes), plus Gaussian noise. That device stands in for the
report's graph paper; the camera is not used because the eye-in-hand sim camera
sees a marker only from a few poses.

Output: the fitted parameters as profile ``arm:`` keys (YAML), the RMS
before and after, and a PNG of the residuals.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from armtree.api.clock import VirtualClock
from armtree.api.emulation import FirmwareEmulator
from armtree.api.rig import Rig
from armtree.cli.options import seed_value
from armtree.errors import ConfigError
from armtree.loader.profile import Profile
from armtree.maths.motion.kinematic_calibration import (
    CalibrationPoints,
    KinematicFit,
    fit_kinematics,
    plot_residuals,
    read_points,
    write_points,
)
from armtree.plugins.trackers.commands import registry_of

#: Structural keys fitted by default, per arm type (Showers 2016: only ``d`` for the Dobot).
DEFAULT_FIT = {"dobot_v1": ("tool_offset_mm",)}
#: Keys ``--fit-links`` adds, per arm type.
LINK_KEYS = {"dobot_v1": ("l1_mm", "l2_mm")}
#: Simulated poses keep the tool this high (mm, base frame) so it clears the sim's objects.
SIM_MIN_Z = 0.0


def configure_kinematics(kinds: Any) -> Any:
    """Add the ``kinematics`` sub-parser to ``kinds`` (the calibrate sub-parsers)."""
    kin = kinds.add_parser(
        "kinematics",
        help="arm link lengths, tool offset, joint offsets by least squares (Showers 2016)",
    )
    source = (
        kin.add_mutually_exclusive_group()
    )  # neither: --rig runs trees/calibrate_kinematics.yaml
    source.add_argument(
        "--points", metavar="FILE", help="CSV (j0..,x,y,z) or YAML points: joints deg, tool mm"
    )
    source.add_argument(
        "--simulate", type=int, metavar="N", help="collect N points on the sim (no hardware)"
    )
    kin.add_argument(
        "--rig",
        metavar="PROFILE",
        help="profile whose arm is calibrated (--simulate: default sim_dobot; alone: run the tree)",
    )
    kin.add_argument(
        "--fit", action="append", default=[], metavar="KEY", help="arm key to fit (repeatable)"
    )
    kin.add_argument("--fit-links", action="store_true", help="fit the link lengths too")
    kin.add_argument("--fit-scales", action="store_true", help="fit joint scale factors too")
    kin.add_argument("--no-offsets", action="store_true", help="keep the joint offsets at 0")
    kin.add_argument(
        "--seed", type=seed_value, default=0, help="--simulate: random poses and noise"
    )
    kin.add_argument(
        "--noise-mm", type=float, default=0.3, help="--simulate: measuring noise, sd (mm)"
    )
    kin.add_argument(
        "--sim-missed-steps",
        default="0.5,1.5,-2.0",
        metavar="A,B,..",
        help="--simulate: missed steps injected per joint (deg / mm) before collecting",
    )
    kin.add_argument(
        "--sim-set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="--simulate: the true arm differs, e.g. tool_offset_mm=48 (the report's pencil)",
    )
    kin.add_argument("--save-points", metavar="FILE.csv", help="--simulate: write the points")
    kin.add_argument("-o", "--output", metavar="FILE.yaml", help="write the fitted arm keys here")
    kin.add_argument("--plot", metavar="FILE.png", help="residuals before/after plot")
    return kin


def run_kinematics(args: argparse.Namespace) -> int:
    """Read or collect points, fit, print and write; 0, or ConfigError for bad input."""
    if (args.points is None) == (args.simulate is None):
        raise ConfigError(
            "calibrate kinematics: give --points FILE or --simulate N, or --rig PROFILE alone "
            "to measure the arm"
        )
    if args.output and Path(args.output).suffix.lower() not in (".yaml", ".yml"):
        raise ConfigError(f"-o {args.output}: the calibration is written as .yaml")
    if args.plot and Path(args.plot).suffix.lower() != ".png":
        raise ConfigError(f"--plot {args.plot}: the plot is written as .png")
    from armtree.loader.profile import load_profile

    args.rig = args.rig or "sim_dobot"
    profile = load_profile(args.rig)
    arm = dict(profile.section("arm") or {})
    if "type" not in arm:
        raise ConfigError(f"profile {args.rig} has no arm")
    factory = registry_of(args).get("arm", arm["type"]).factory
    make_model = getattr(factory, "model", None)
    if make_model is None:
        raise ConfigError(f"arm type {arm['type']!r} offers no kinematic model to calibrate")
    free = _free_keys(args, arm["type"])
    params = {p.name: p.default for p in getattr(factory, "PARAMS", ())}
    initial = {}
    for key in free:
        value = arm.get(key, params.get(key))
        if not isinstance(value, int | float):
            raise ConfigError(f"--fit {key}: arm type {arm['type']!r} has no number {key}")
        initial[key] = float(value)
    dof = make_model(arm).dof
    if args.simulate is not None:
        points, device = _simulate(args, profile, make_model, arm, dof)
        if args.save_points:
            write_points(args.save_points, points)
            print(f"wrote {args.save_points}")
    else:
        points, device = read_points(args.points, dof), f"points from {args.points}"
    fit = fit_kinematics(
        lambda p: make_model({**arm, **p}),
        initial,
        points,
        free=free,
        fit_offsets=not args.no_offsets,
        fit_scales=args.fit_scales,
    )
    _report(fit, len(points.joints_deg), device)
    if args.output:
        _write(args.output, fit, arm["type"], len(points.joints_deg), device)
        print(f"wrote {args.output} (a profile uses it with include: {args.output})")
    if args.plot:
        plot_residuals(fit, args.plot)
        print(f"wrote {args.plot}")
    return 0


def _free_keys(args: argparse.Namespace, arm_type: str) -> tuple[str, ...]:
    keys = list(args.fit) or list(DEFAULT_FIT.get(arm_type, ()))
    if args.fit_links:
        if arm_type not in LINK_KEYS:
            raise ConfigError(f"--fit-links: name the {arm_type} link keys with --fit KEY")
        keys += [k for k in LINK_KEYS[arm_type] if k not in keys]
    return tuple(keys)


def _report(fit: KinematicFit, n: int, device: str) -> None:
    print(f"kinematic calibration (Showers 2016, least squares on the FK), {n} points; {device}")
    for key in fit.free:
        sd = fit.std_errors.get(key, 0.0)
        print(f"  {key}: {fit.initial[key]:.3f} -> {fit.params[key]:.3f} (+/- {sd:.3f})")
    print(f"  joint offsets (deg): {np.round(fit.joint_offsets_deg, 3).tolist()}")
    print(f"  joint scales: {np.round(fit.joint_scales, 4).tolist()}")
    print(f"  RMS error before {fit.rms_before_mm:.3f} mm, after {fit.rms_after_mm:.3f} mm")


def _write(path: str, fit: KinematicFit, arm_type: str, n: int, device: str) -> None:
    arm: dict[str, Any] = {"type": arm_type}
    arm.update({k: round(fit.params[k], 4) for k in fit.free})
    arm["joint_offsets_deg"] = [round(float(v), 4) for v in fit.joint_offsets_deg]
    arm["joint_scales"] = [round(float(v), 6) for v in fit.joint_scales]
    data = {
        "arm": arm,
        "calibration": {"records": {"kinematics": {
            "method": "least squares on the forward kinematics (Showers 2016, Model Validation)",
            "points": n,
            "source": device,
            "rms_before_mm": round(fit.rms_before_mm, 4),
            "rms_after_mm": round(fit.rms_after_mm, 4),
            "std_errors": {k: round(v, 5) for k, v in fit.std_errors.items()},
        }}},
    }  # fmt: skip
    header = "# Kinematic calibration (Showers 2016): a profile takes it with include: FILE\n"
    Path(path).write_text(header + yaml.safe_dump(data, sort_keys=False))


# ---------------------------------------------------------------------- --simulate


def _sim_set(items: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"--sim-set {item}: write KEY=VALUE")
        out[key.strip()] = yaml.safe_load(value)
    return out


def _simulate(
    args: argparse.Namespace,
    profile: Profile,
    make_model: Any,
    arm: Mapping[str, Any],
    dof: int,
) -> tuple[CalibrationPoints, str]:
    """Drive the sim arm to random poses; measure with the simulated measuring device."""
    from rich.console import Console
    from rich.progress import Progress

    from armtree.hooks.plugin_manager import get_plugin_manager
    from armtree.runtime.rig_builder import build_rig

    if args.simulate < 1:
        raise ConfigError(f"--simulate {args.simulate}: give a positive number of points")
    if arm.get("port", "sim") != "sim":
        raise ConfigError(f"--simulate: profile {args.rig}'s arm is not simulated (port: sim)")
    missed = [float(v) for v in args.sim_missed_steps.split(",") if v.strip()]
    if len(missed) > dof:
        raise ConfigError(f"--sim-missed-steps: at most {dof} values")
    truth = make_model({**arm, **_sim_set(args.sim_set)})
    nominal = make_model(arm)
    rng = np.random.default_rng(args.seed)
    clock = VirtualClock()
    manager = getattr(args, "manager", None) or get_plugin_manager()
    rig = build_rig(profile, manager, clock, seed=args.seed)
    joints: list[np.ndarray] = []
    measured: list[np.ndarray] = []
    try:
        emulator = _emulator_of(rig)
        driver = rig.arm
        if driver is None:
            raise ConfigError(f"--simulate: profile {args.rig} builds no arm")
        for joint, amount in enumerate(missed):
            if amount:
                emulator.inject("missed_steps", joint=joint, amount=amount)
        with Progress(console=Console(stderr=True), transient=True) as progress:
            task = progress.add_task("collecting calibration points", total=args.simulate)
            tries = 0
            while len(joints) < args.simulate and tries < 20 * args.simulate:
                tries += 1
                q = _random_pose(nominal, rng)
                handle = driver.move_joints(q)
                for _ in range(4000):
                    if handle.done:
                        break
                    rig.step(clock.advance(0.05))
                if handle.status.value != "done":
                    continue
                joints.append(np.asarray(driver.joints(), dtype=float))
                # The simulated measuring device: ground truth plus noise, measurement only.
                true_tool = truth.position(np.asarray(emulator.true_joints(), dtype=float))
                measured.append(true_tool + rng.normal(0.0, args.noise_mm, 3))
                progress.advance(task)
    finally:
        rig.close()
    if len(joints) < args.simulate:
        raise ConfigError(f"--simulate: only {len(joints)} of {args.simulate} moves completed")
    device = (
        "simulated measuring device: the sim's true tool position (emulator true joints, "
        f"missed steps {missed} injected"
        + (f", true arm {', '.join(args.sim_set)}" if args.sim_set else "")
        + f") plus {args.noise_mm:g} mm Gaussian noise"
    )
    return CalibrationPoints(np.array(joints), np.array(measured), "simulation"), device


def _emulator_of(rig: Rig) -> FirmwareEmulator:
    # serve_in_run adds each emulator's step to the rig's steppers.
    for stepper in rig.steppers:
        owner = getattr(stepper, "__self__", None)
        if isinstance(owner, FirmwareEmulator):
            return owner
    raise ConfigError("--simulate: the rig has no arm emulator")


def _random_pose(model: Any, rng: np.random.Generator) -> np.ndarray:
    """Uniform joints within the limits and constraints, tool at z >= SIM_MIN_Z (mm)."""
    for _ in range(1000):
        q = rng.uniform(model.lower, model.upper, (64, model.dof))
        ok = model.within_limits(q) & (model.position(q)[:, 2] >= SIM_MIN_Z)
        if ok.any():
            return q[np.argmax(ok)]
    raise ConfigError("--simulate: no random pose within the joint limits reaches z >= 0")
