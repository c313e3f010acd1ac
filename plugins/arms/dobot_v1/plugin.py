"""Registration of the built-in dobot_v1 plugin: ``arm: {type: dobot_v1}``.

``firmware: original`` (the 42-byte frame protocol, 9600 baud by default) or
``firmware: open-dobot`` (the replacement firmware's request/response
protocol, 115200 baud). ``port: sim`` starts the matching firmware emulator on
a pseudo-terminal and drives it through the same pyserial driver.
"""

from __future__ import annotations

from typing import Any, cast

import numpy as np

import armtree
from armtree.api.clock import Clock
from armtree.api.rig import ArmDriver, RigContext
from armtree.config.params import Param
from armtree.errors import ConfigError
from armtree.plugins.arms.common.factory import ArmFactory

from ..common import PtyEmulator, driver_port, on_emulator
from .driver import DobotV1Driver
from .emulator import DobotV1Emulator
from .kinematics import DEFAULT_TOOL_OFFSET, L1, L2, DobotV1Model

FIRMWARES = ("original", "open-dobot")
DEFAULT_BAUD = {"original": 9600, "open-dobot": 115200}


def _firmware(config: dict[str, Any]) -> str:
    firmware = config.get("firmware", "original")
    if firmware not in FIRMWARES:
        raise ConfigError(f"arm.firmware: {firmware!r} is not one of {', '.join(FIRMWARES)}")
    return firmware


def dobot_v1_model(config: dict[str, Any]) -> DobotV1Model:
    """The Dobot V1.0 kinematic model of a profile's ``arm`` mapping (no port opened)."""
    return DobotV1Model(
        tool_offset_mm=float(config.get("tool_offset_mm", DEFAULT_TOOL_OFFSET)),
        tool_drop_mm=float(config.get("tool_drop_mm", 0.0)),
        l1_mm=float(config.get("l1_mm", L1)),
        l2_mm=float(config.get("l2_mm", L2)),
        joint_offsets_deg=_triple(config, "joint_offsets_deg", 0.0),
        joint_scales=_triple(config, "joint_scales", 1.0),
    )


def _triple(config: dict[str, Any], key: str, default: float) -> tuple[float, float, float]:
    value = config.get(key)
    if value is None:
        return (default, default, default)
    values = tuple(float(v) for v in value)
    if len(values) != 3 or (key == "joint_scales" and 0.0 in values):
        raise ConfigError(f"arm.{key}: three numbers (base, rear arm, forearm) are required"
                          + (", none of them 0" if key == "joint_scales" else ""))  # fmt: skip
    return values


def dobot_v1_emulator(config: dict[str, Any], clock: Clock, seed: int = 0) -> PtyEmulator:
    """The firmware emulator (not started) that ``config`` asks for, on ``clock``."""
    model = dobot_v1_model(config)
    q0 = config.get("start_pose")
    q0 = None if q0 is None else np.asarray(q0, dtype=float)
    if _firmware(config) == "open-dobot":
        from .opendobot_emulator import OpenDobotEmulator

        return OpenDobotEmulator(model, clock, seed=seed, q0=q0, board=config.get("board", "fpga"))
    return DobotV1Emulator(
        model,
        clock,
        seed=seed,
        q0=q0,
        status_period=float(config.get("status_period", 0.05)),
    )


_DobotV1Factory = ArmFactory[DobotV1Model, PtyEmulator, ArmDriver]


def dobot_v1_factory(config: dict[str, Any], context: RigContext) -> ArmDriver:
    """Dobot V1.0 (original or open-dobot firmware) over pyserial; ``port: sim`` emulates it."""
    firmware = _firmware(config)
    model = dobot_v1_model(config)
    simulated = on_emulator(config)
    port, options = driver_port(
        config, context, lambda: dobot_v1_emulator(config, context.clock, seed=context.seed)
    )
    baud = int(config.get("baud") or DEFAULT_BAUD[firmware])
    common = {
        "baud": baud,
        "link_timeout": float(config.get("link_timeout", 1.0)),
        # A real Arduino resets when the port opens and boots for about 2 s (Dobot protocol, serial settings).
        "connect_timeout": 3.0 if simulated else float(config.get("connect_timeout", 8.0)),
        **options,
    }
    if firmware == "open-dobot":
        from .opendobot_driver import OpenDobotDriver

        return OpenDobotDriver(model, port, board=config.get("board", "fpga"), **common)
    driver = DobotV1Driver(model, port, **common)
    # after the emulator's step: its homing acts on what the board sent this tick
    context.steppers.append(driver.step)
    return driver


# mypy types a def as a plain callable, which has no attributes to set: the same function,
# typed as what it is once the members below are set.
dobot_v1_factory = cast(_DobotV1Factory, dobot_v1_factory)
dobot_v1_factory.PARAMS = (
    Param("port", "str", "sim", doc="serial device (/dev/ttyUSB0, COM3), or sim for the emulator"),
    Param("firmware", "str", "original", doc="firmware on the arm", choices=FIRMWARES),
    Param(
        "baud",
        "int",
        0,
        doc="serial speed; 0 = the firmware's default (9600 original, 115200 open-dobot; "
        "the first original firmware used 256000)",
        minimum=0,
        maximum=4_000_000,
    ),
    Param(
        "tool_offset_mm",
        "float",
        DEFAULT_TOOL_OFFSET,
        unit="mm",
        doc="wrist-to-tool, horizontal (report's d)",
        minimum=-500.0,
        maximum=500.0,
    ),
    Param(
        "tool_drop_mm",
        "float",
        0.0,
        unit="mm",
        doc="tool centre below the wrist joint",
        minimum=-500.0,
        maximum=500.0,
    ),
    Param(
        "l1_mm",
        "float",
        L1,
        unit="mm",
        doc="rear arm length (Showers 2016: 135; calibrated)",
        exclusive_minimum=0.0,
        maximum=2000.0,
    ),
    Param(
        "l2_mm",
        "float",
        L2,
        unit="mm",
        doc="forearm length (Showers 2016: 160; calibrated)",
        exclusive_minimum=0.0,
        maximum=2000.0,
    ),
    Param(
        "joint_offsets_deg",
        "vector",
        None,
        unit="deg",
        doc="added to the scaled reported angles (armtree calibrate kinematics; default 0)",
        minimum=-360.0,
        maximum=360.0,
        length=3,
    ),
    Param(
        "joint_scales",
        "vector",
        None,
        doc="factors on the reported angles (armtree calibrate kinematics; default 1)",
        minimum=0.1,
        maximum=10.0,
        length=3,
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
        "connect_timeout",
        "float",
        8.0,
        unit="s",
        doc="real ports: time allowed for the board's reset and first answer",
        minimum=0.1,
        maximum=600.0,
    ),
    Param(
        "status_period",
        "float",
        0.05,
        unit="s",
        doc="sim only: status frame period (original)",
        minimum=0.005,
        maximum=1.0,
    ),
    Param("board", "str", "fpga", doc="open-dobot control board", choices=("fpga", "ramps")),
    Param(
        "start_pose",
        "vector",
        None,
        unit="deg",
        doc="sim only: power-up joint angles",
        minimum=-360.0,
        maximum=360.0,
        length=3,
    ),
)
dobot_v1_factory.model = dobot_v1_model
dobot_v1_factory.simulated = on_emulator
dobot_v1_factory.emulator = dobot_v1_emulator
#: What the skills grip with (set_suction): the suction cup.
dobot_v1_factory.grips_with = lambda config: "suction"


@armtree.hookimpl
def armtree_arms() -> dict[str, Any]:
    """Register ``dobot_v1``."""
    return {"dobot_v1": dobot_v1_factory}
