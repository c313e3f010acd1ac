"""Registration of the bus-servo arms: ``bus_servo`` (any URDF arm on Feetech or Dynamixel
servos) and its presets ``so101`` (SO-101, six STS3215) and ``koch`` (Koch v1.1, XL430 and
XL330).

``arm: {type: so101, port: /dev/ttyACM0}`` is a whole SO-101; ``type: bus_servo`` takes
the same keys with no defaults for the arm (``bus``, ``urdf``, ``servos``). ``port:
sim`` builds the bus emulator, its servos mounted on the arm as the calibration says
(or, uncalibrated, as the preset's simulated arm was built, :data:`SIM_HORNS`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, Protocol, cast

import armtree
from armtree.api.clock import Clock
from armtree.api.rig import RigContext
from armtree.config.params import Param
from armtree.maths.motion.collision import CollisionChecker
from armtree.maths.motion.scene import Scene
from armtree.maths.motion.urdf import UrdfModel
from armtree.plugins.arms.common import driver_port, on_emulator
from armtree.plugins.arms.common.factory import ArmFactory
from armtree.plugins.arms.common.pty_emulator import FAULTS
from armtree.runtime.run_end import RunResult
from armtree.runtime.runner import Run

from .calibrate import calibrate_servos
from .calibration import MIDDLE
from .driver import TRAJECTORY_KINDS, BusServoDriver
from .emulator import BUS_FAULTS, BusServoEmulator, Mount
from .servo import SimServo
from .spec import ArmSpec, arm_model, arm_spec
from .tables import protocol_for

_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll")

#: The arms armtree knows by name: what their ``arm:`` keys default to.
PRESETS: dict[str, dict[str, Any]] = {
    "so101": {
        "name": "so101",
        "bus": "feetech",
        "urdf": "so101.urdf",
        "servos": {j: {"id": i, "model": "sts3215"} for i, j in enumerate(_JOINTS, start=1)},
        "gripper": {"id": 6, "model": "sts3215", "closed": 0.0, "open": 45.0},
        "home": [0.0, -28.0, 29.0, 89.0, 0.0],
    },
    "koch": {
        "name": "koch",
        "bus": "dynamixel",
        "urdf": "koch.urdf",
        "servos": {
            j: {"id": i, "model": "xl430-w250" if i <= 2 else "xl330-m288"}
            for i, j in enumerate(_JOINTS, start=1)
        }
        | {
            "shoulder_lift": {"id": 2, "model": "xl430-w250", "direction": -1},
            "wrist_flex": {"id": 4, "model": "xl330-m288", "direction": -1},
        },
        "gripper": {"id": 6, "model": "xl330-m288", "closed": 0.0, "open": 45.0},
        "home": [1.0, 90.0, 70.0, 110.0, 0.0],
    },
}
#: Where each simulated arm's servo horns sit at each joint's zero (counts), before any
#: calibration: as a kit is put together, each joint's range well inside the turn and
#: none of them quite where a calibration would put it.
SIM_HORNS: dict[str, dict[str, int]] = {
    "so101": {
        "shoulder_pan": 2011,
        "shoulder_lift": 1987,
        "elbow_flex": 2110,
        "wrist_flex": 2061,
        "wrist_roll": 2048,
        "gripper": 2002,
    },
    "koch": {
        "shoulder_pan": 2060,
        "shoulder_lift": 2863,
        "elbow_flex": 1053,
        "wrist_flex": 2423,
        "wrist_roll": 2048,
        "gripper": 1479,
    },
}


def _config(config: Mapping[str, Any], preset: str | None) -> dict[str, Any]:
    """The arm section with every key's default under it (the preset's for a preset; the
    profile's keys win), as a loaded profile gives it and as ``armtree emulate`` does not."""
    defaults = {p.name: p.default for p in _params(PRESETS.get(preset or "", {}))}
    return {**defaults, **{k: v for k, v in config.items() if v is not None}}


def emulator_for(
    config: Mapping[str, Any], clock: Clock, seed: int = 0, preset: str | None = None
) -> BusServoEmulator:
    """The arm's servo bus emulator (not started). Each servo's horn is mounted as the
    calibration says (its EEPROM holding that homing offset), else as the preset's
    simulated arm was built (:data:`SIM_HORNS`, homing offset 0); the arm at home."""
    config = _config(config, preset)
    spec, model = arm_spec(config), arm_model(config)
    horns = SIM_HORNS.get(preset or "", {})
    servos, mounts = [], {}
    angles = dict(zip([j.name for j in model.joints], model.home.tolist(), strict=True))
    if spec.gripper is not None:
        angles[spec.gripper.joint] = spec.grip_open
    for link in spec.links:
        sign = link.model.offset_sign
        if link.calibrated:
            offset = link.calibration.homing_offset
            zero = MIDDLE - sign * offset
        else:
            offset, zero = 0, horns.get(link.joint, MIDDLE)
        mount = Mount(link.id, float(zero), link.calibration.direction)
        mounts[link.joint] = mount
        servos.append(
            SimServo(
                link.model,
                link.id,
                mount.counts(angles[link.joint]),
                homing_offset=offset,
                baud=spec.baud,
            )
        )
    return BusServoEmulator(
        model,
        clock,
        protocol_for(spec.bus),
        servos,
        [mounts[j.name] for j in model.joints],
        gripper=None if spec.gripper is None else mounts[spec.gripper.joint],
        latency_s=float(config.get("latency_s", 0.0)),
        seed=seed,
    )


class _BusServoFactory(ArmFactory[UrdfModel, BusServoEmulator, BusServoDriver], Protocol):
    """A bus-servo factory's members (:func:`_factory`), and its spec, servo
    calibration and the faults its emulator can play."""

    spec: Callable[[dict[str, Any]], ArmSpec]
    calibrate_servos: Callable[..., dict[str, dict[str, int]]]  # (config, profile, **io)
    faults: tuple[str, ...]


def _factory(preset: str | None) -> _BusServoFactory:
    """The factory of ``type: bus_servo`` (``preset`` None) or of one preset."""

    def factory(config: dict[str, Any], context: RigContext) -> BusServoDriver:
        """A bus-servo arm (``port: sim``: on its bus emulator)."""
        full = _config(config, preset)
        spec, model = arm_spec(full), arm_model(full)
        port, options = driver_port(
            full, context, lambda: emulator_for(full, context.clock, context.seed, preset)
        )
        return BusServoDriver(
            model,
            port,
            spec,
            trajectory=str(full.get("trajectory", "cubic")),
            stream_period=float(full.get("stream_period_s", 0.05)),
            poll_period=float(full.get("poll_period_s", 0.02)),
            reply_timeout=float(full.get("reply_timeout_s", 0.05)),
            retries=int(full.get("retries", 3)),
            link_timeout=float(full.get("link_timeout", 1.0)),
            # the profile's table and obstacles: a trajectory through them is refused
            checker=CollisionChecker(model, Scene.from_profile(context.profile or {})),
            **options,
        )

    def model(config: dict[str, Any]) -> UrdfModel:
        """The arm's URDF model, its limits cut to the calibrated ranges."""
        return arm_model(_config(config, preset))

    def spec(config: dict[str, Any]) -> ArmSpec:
        """The arm's servos, checked."""
        return arm_spec(_config(config, preset))

    # mypy types a def as a plain callable, which has no attributes to set: the same
    # function, typed as what it is once the members below are set.
    factory = cast(_BusServoFactory, factory)
    factory.model = model
    factory.spec = spec
    factory.simulated = on_emulator
    factory.emulator = lambda config, clock, seed=0: emulator_for(config, clock, seed, preset)
    factory.calibrate_servos = lambda config, profile, **io: {
        joint: c.as_dict()
        for joint, c in calibrate_servos(factory, _config(config, preset), profile, **io).items()
    }
    factory.grips_with = lambda config: (
        "gripper" if _config(config, preset).get("gripper") is not None else None
    )
    #: Faults the emulator takes (``world.faults``), besides every emulator's.
    factory.faults = (*FAULTS, *BUS_FAULTS)
    factory.PARAMS = _params(PRESETS.get(preset or "", {}))
    factory.__doc__ = {
        None: "Any URDF arm on Feetech or Dynamixel bus servos (port: sim for the emulator).",
        "so101": "The SO-101: six Feetech STS3215 bus servos, hardware/so101.urdf "
        "(port: sim for the emulator).",
        "koch": "The Koch v1.1: Dynamixel XL430 and XL330 servos (Protocol 2.0), "
        "hardware/koch.urdf (port: sim for the emulator).",
    }[preset]
    return factory


def _params(preset: dict[str, Any]) -> tuple[Param, ...]:
    """The keys of ``arm:``, their defaults the preset's."""
    required = not preset
    return (
        Param("port", "str", "sim", doc="the bus adapter's serial device, or sim for the emulator"),
        Param(
            "baud",
            "int",
            1_000_000,
            unit="baud",
            doc="the servos' baud rate (Feetech: 1,000,000 down to 19,200; Dynamixel X: 9,600 "
            "up to 4,500,000)",
            minimum=1,
            maximum=10_000_000,
        ),
        Param("name", "str", preset.get("name"), doc="the arm's name in messages"),
        Param(
            "bus",
            "str",
            None if required else preset["bus"],
            doc="the servos' protocol: feetech (STS/SCS) or dynamixel (Protocol 2.0)",
            choices=("feetech", "dynamixel"),
        ),
        Param(
            "urdf",
            "str",
            None if required else preset["urdf"],
            doc="the arm's URDF file: a path (absolute or from the working directory) or a "
            "shipped one (so101.urdf, koch.urdf)",
        ),
        Param("tool_link", "str", "tcp", doc="the URDF link whose frame is the tool centre"),
        Param("base_link", "str", None, doc="the URDF link the arm stands on (default: its root)"),
        Param(
            "tool_axis",
            "vector",
            [0.0, 0.0, -1.0],
            doc="position targets keep the tool frame's z axis along this base-frame direction "
            "(a gripper pointing down)",
            length=3,
        ),
        Param(
            "home",
            "vector",
            preset.get("home"),
            unit="deg",
            doc="the home pose, one angle per joint; with tool_axis, the tool along it",
        ),
        Param(
            "servos",
            "dict",
            None if required else preset["servos"],
            doc="each URDF joint's servo: {JOINT: {id, model (sts3215, xl430-w250, xl330-m288), "
            "direction (1 or -1)}}",
        ),
        Param(
            "gripper",
            "dict",
            preset.get("gripper"),
            doc="the gripper's servo: {id, model, closed, open (degrees of its joint), joint "
            "(its name in the calibration, default gripper)}",
        ),
        Param(
            "calibration",
            "dict",
            None,
            doc="per joint {id, drive_mode, homing_offset, range_min, range_max} (counts), as "
            "'armtree calibrate servos' writes it into a file the profile includes",
        ),
        Param(
            "max_accel",
            "float",
            300.0,
            unit="deg/s^2",
            doc="every joint's acceleration limit",
            minimum=1.0,
            maximum=1e5,
        ),
        Param(
            "trajectory",
            "str",
            "cubic",
            doc="how the host times a motion: cubic (Pozzani 2023, eq. 2) or quintic polynomials, "
            "streamed as set points",
            choices=TRAJECTORY_KINDS,
        ),
        Param(
            "stream_period_s",
            "float",
            0.05,
            unit="s",
            doc="time between set points",
            minimum=0.005,
            maximum=1.0,
        ),
        Param(
            "poll_period_s",
            "float",
            0.02,
            unit="s",
            doc="time between reads of every servo's state",
            minimum=0.001,
            maximum=1.0,
        ),
        Param(
            "reply_timeout_s",
            "float",
            0.05,
            unit="s",
            doc="how long a status packet may take before it is asked for again",
            minimum=0.001,
            maximum=10.0,
        ),
        Param(
            "retries",
            "int",
            3,
            doc="how many times a lost status packet is asked for again before the link is lost",
            minimum=0,
            maximum=20,
        ),
        Param(
            "link_timeout",
            "float",
            1.0,
            unit="s",
            doc="silence after which the link is lost",
            minimum=0.05,
            maximum=600.0,
        ),
        Param(
            "latency_s",
            "float",
            0.0,
            unit="s",
            doc="the emulator only: how late each status packet comes",
            minimum=0.0,
            maximum=10.0,
        ),
    )


bus_servo_factory = _factory(None)
so101_factory = _factory("so101")
koch_factory = _factory("koch")


@armtree.hookimpl
def armtree_arms() -> dict[str, Any]:
    """Register ``bus_servo``, ``so101`` and ``koch``."""
    return {"bus_servo": bus_servo_factory, "so101": so101_factory, "koch": koch_factory}


@armtree.hookimpl
def armtree_run_finished(run: Run, result: RunResult) -> None:
    """A run on a bus-servo arm records how its bus went: the status packets lost (each
    asked again) in the log (a ``servo_bus`` event) and in the summary (``servo bus:``)."""
    arm = getattr(getattr(run, "rig", None), "arm", None)
    if not isinstance(arm, BusServoDriver):
        return
    facts = arm.bus_facts()
    run.report_event("servo_bus", None, **facts)
    details = getattr(result, "details", None)
    if isinstance(details, dict):
        details["servo bus"] = (
            f"{facts['lost_status']} status packets lost, each asked again "
            f"(up to {facts['retries']} times a request)"
        )


__all__ = [
    "PRESETS",
    "SIM_HORNS",
    "bus_servo_factory",
    "emulator_for",
    "koch_factory",
    "so101_factory",
]
