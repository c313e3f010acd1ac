"""``armtree calibrate servos --rig P``: a bus-servo arm's homing offsets and ranges.

The arm plugin does the calibrating (``factory.calibrate_servos(config, profile,
ready=, say=)``, the arm moved by hand with torque off; on ``port: sim`` a simulated
hand moves it) and returns each joint's ``{id, drive_mode, homing_offset, range_min,
range_max}``; this command writes them as ``arm: {calibration: ...}`` into the
calibration file (``-o``, default ``calibration.yaml``), which the profile includes.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from armtree.config.calibration import update_calibration_file
from armtree.errors import ConfigError


def configure_servos(kinds: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``servos`` and its options."""
    srv = kinds.add_parser(
        "servos", help="bus servos' homing offsets and ranges, the arm moved by hand (SO-101, Koch)"
    )
    srv.add_argument("--rig", required=True, metavar="PROFILE", help="the arm's profile")
    srv.add_argument(
        "-o",
        "--output",
        metavar="FILE.yaml",
        help="the calibration file (default calibration.yaml)",
    )
    return srv


def run_servos(args: argparse.Namespace) -> int:
    """Calibrate, write the file, print what each servo measured; 0, or ConfigError."""
    from armtree.loader.profile import load_profile

    manager = getattr(args, "manager", None)
    if manager is None:
        from armtree.hooks.plugin_manager import get_plugin_manager

        manager = get_plugin_manager()
    out = Path(args.output or "calibration.yaml")
    if out.suffix.lower() not in (".yaml", ".yml"):
        raise ConfigError(f"-o {out}: the calibration is written as .yaml")
    profile = load_profile(args.rig, manager=manager)
    arm = profile.component("arm") or {}
    factory = manager.registry.get("arm", arm.get("type", "")).factory if arm else None
    calibrate = getattr(factory, "calibrate_servos", None)
    if calibrate is None:
        raise profile.error(
            "arm.type",
            f"the {arm.get('type')} arm has no bus servos to calibrate "
            "(so101, koch and bus_servo arms do)",
        )
    found = calibrate(arm, profile, ready=lambda text: input(text), say=print)
    update_calibration_file(
        out, {"arm": {"calibration": found}}, record=("servos", {"rig": profile.name})
    )
    print(f"{'joint':14s} {'id':>3s} {'drive':>5s} {'offset':>7s} {'range (counts)':>16s}")
    for joint, c in found.items():
        span = f"{c['range_min']}-{c['range_max']}"
        print(f"{joint:14s} {c['id']:3d} {c['drive_mode']:5d} {c['homing_offset']:7d} {span:>16s}")
    print(f"wrote {out}: the profile uses it with `include: {out.name}`")
    return 0
