"""Registration of the built-in dh plugin: ``arm: {type: dh, dh: {convention, table}}``."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, cast

import numpy as np

import armtree
from armtree.api.clock import Clock
from armtree.api.rig import RigContext
from armtree.config.params import Param
from armtree.errors import ConfigError
from armtree.loader.profile import Profile
from armtree.maths.motion.collision import CollisionChecker
from armtree.maths.motion.scene import Scene
from armtree.plugins.arms.common import driver_port, on_emulator
from armtree.plugins.arms.common.factory import ArmFactory

from .driver import TRAJECTORY_KINDS, SSC32Driver
from .emulator import SSC32Emulator
from .kinematics import DHModel, model_from_config
from .ssc32 import ServoMap, servo_maps_from_config


def _servos(config: dict[str, Any], n: int) -> list[ServoMap]:
    return servo_maps_from_config(config.get("servos"), n)


def _grip_angles(config: dict[str, Any]) -> tuple[float, float]:
    """The gripper servo's closed and open angles (degrees), from ``arm.gripper``."""
    spec = config.get("gripper") or {}
    closed, opened = spec.get("closed", 0.0), spec.get("open", 90.0)
    for key, value in (("closed", closed), ("open", opened)):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"arm.gripper.{key}: expected an angle in degrees, got {value!r}")
    return float(closed), float(opened)


def _grips_with(config: dict[str, Any]) -> str | None:
    """What the skills grip with (set_suction): ``tool``, else the gripper when there is
    one and no pump, else the pump; None when the arm has neither."""
    tool = config.get("tool")
    has_pump = config.get("suction_channel") is not None
    has_gripper = config.get("gripper") is not None
    if tool is None:
        tool = "gripper" if has_gripper and not has_pump else "suction"
    return tool if {"gripper": has_gripper, "suction": has_pump}.get(tool) else None


def _gripper(config: dict[str, Any]) -> ServoMap | None:
    spec = config.get("gripper")
    if spec is None:
        return None
    maps = servo_maps_from_config([spec], 1)
    return maps[0]


def _model(config: dict[str, Any]) -> DHModel:
    """The arm's DH model; each joint's limits are cut to what its servo reaches."""
    base = model_from_config(config)
    servos = _servos(config, base.dof)
    limits = []
    for joint, servo in zip(base.joints, servos, strict=True):
        lo, hi = servo.range()
        lo, hi = max(lo, joint.lower), min(hi, joint.upper)
        if lo >= hi:
            raise ConfigError(
                f"arm.servos: joint {joint.name}'s servo range does not overlap its limits "
                f"[{joint.lower:g}, {joint.upper:g}]"
            )
        limits.append((lo, hi))
    dh = config["dh"]
    home = dh.get("home")
    return DHModel(
        base.rows,
        limits,
        base.convention,
        name=str(config.get("name", "dh")),
        tool_offset=base.tool_offset,
        base=base.base,
        home=None if home is None else np.asarray(home, dtype=float),
        seeds=int(dh.get("ik_seeds", 12)),
        link_width=base.link_width,
        tool_axis=base.tool_axis,
        tool_boxes=base.tool_boxes,
    )


def _emulator(config: dict[str, Any], clock: Clock, seed: int = 0) -> SSC32Emulator:
    """The SSC-32 board emulator (not started) for the arm in ``config``."""
    model = _model(config)
    return SSC32Emulator(
        model,
        clock,
        _servos(config, model.dof),
        gripper=_gripper(config),
        suction_channel=config.get("suction_channel"),
        seed=seed,
    )


class _DHFactory(ArmFactory[DHModel, SSC32Emulator, SSC32Driver], Protocol):
    """:func:`dh_factory`'s members, and the load-time check of its chain."""

    validate: Callable[[dict[str, Any], Profile], None]


def dh_factory(config: dict[str, Any], context: RigContext) -> SSC32Driver:
    """Any serial arm from a DH table, its joints on an SSC-32 servo board (``port: sim``)."""
    model = _model(config)
    servos = _servos(config, model.dof)
    port, options = driver_port(
        config,
        context,
        lambda: SSC32Emulator(
            model,
            context.clock,
            servos,
            gripper=_gripper(config),
            suction_channel=config.get("suction_channel"),
            seed=context.seed,
        ),
    )
    return SSC32Driver(
        model,
        port,
        servos,
        gripper=_gripper(config),
        suction_channel=config.get("suction_channel"),
        tool=config.get("tool"),
        grip_angles=_grip_angles(config),
        baud=int(config.get("baud", 115200)),
        link_timeout=float(config.get("link_timeout", 1.0)),
        trajectory=str(config.get("trajectory", "cubic")),
        stream_period=float(config.get("stream_period_s", 0.05)),
        # the profile's table and obstacles: a trajectory through them is refused
        checker=CollisionChecker(model, Scene.from_profile(context.profile or {})),
        **options,
    )


# mypy types a def as a plain callable, which has no attributes to set: the same function,
# typed as what it is once the members below are set.
dh_factory = cast(_DHFactory, dh_factory)


def _validate(config: dict[str, Any], profile: Profile) -> None:
    """Load-time checks beyond the model's (``armtree check``): the gripper servo."""
    _grip_angles(config)
    _gripper(config)


dh_factory.validate = _validate
dh_factory.PARAMS = (
    Param("port", "str", "sim", doc="serial device of the SSC-32, or sim for the emulator"),
    Param(
        "baud",
        "int",
        115200,
        doc="SSC-32 baud rate (jumpers: 2400, 9600, 38400, 115200)",
        minimum=0,
        maximum=4_000_000,
    ),
    Param("name", "str", "dh", doc="the arm's name in messages"),
    Param(
        "dh",
        "dict",
        doc="convention (modified|standard), table of {a, alpha, d, theta, type, limits} "
        "in mm and degrees, tool_offset_mm, base_mm, home, ik_seeds",
    ),
    Param(
        "servos",
        "list",
        None,
        doc="one {channel, table: [[pulse_us, angle], ...]} per joint, fitted by least squares",
    ),
    Param(
        "gripper",
        "dict",
        None,
        doc="gripper servo {channel, table, closed, open}: closed and open in degrees "
        "(default 0 and 90)",
    ),
    Param(
        "suction_channel",
        "int",
        None,
        doc="SSC-32 output driving a pump (#<ch>H / #<ch>L)",
        minimum=0,
        maximum=31,
    ),
    Param(
        "tool",
        "str",
        None,
        doc="what grips: suction (the pump) or gripper; default: the gripper when there "
        "is one and no pump",
        choices=("suction", "gripper"),
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
        "trajectory",
        "str",
        "cubic",
        doc="how the host times a motion for the board: cubic (Pozzani 2023, eq. 2) or quintic "
        "polynomials streamed as short group moves, or none (one group move per target)",
        choices=TRAJECTORY_KINDS,
    ),
    Param(
        "stream_period_s",
        "float",
        0.05,
        unit="s",
        doc="time between the set points streamed along a trajectory",
        minimum=0.005,
        maximum=1.0,
    ),
)
dh_factory.model = _model
dh_factory.simulated = on_emulator
dh_factory.emulator = _emulator
dh_factory.grips_with = _grips_with


@armtree.hookimpl
def armtree_arms() -> dict[str, Any]:
    """Register ``dh``."""
    return {"dh": dh_factory}
