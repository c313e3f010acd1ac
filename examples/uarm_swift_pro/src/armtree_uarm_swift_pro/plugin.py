"""The uFactory uArm Swift Pro as an armtree plugin: ``arm: {type: uarm_swift_pro}``.

armtree finds this module through the ``armtree`` entry point of this package;
nothing in armtree itself knows about the arm. ``port: sim`` starts the
firmware emulator on a pseudo-terminal and points the real driver at it, so
armtree's trees, planners, workspace tool and simulation work with the arm
unchanged; ``port: /dev/ttyACM0`` (the arm's Arduino Mega, USB VID:PID
2341:0042) drives the real one.
"""

from __future__ import annotations

from typing import Any

import armtree
from armtree.api.clock import Clock
from armtree.api.rig import RigContext
from armtree.plugins.arms.common import driver_port, on_emulator

from .driver import SwiftProDriver
from .emulator import SwiftProEmulator
from .kinematics import MODES, SwiftProModel

#: The armtree versions this plugin supports; another one refuses to load it.
ARMTREE_REQUIRES = ">=0.1,<0.2"
#: Work modes whose end effector is a suction cup.
SUCTION_MODES = (0, 4, 5)


def model(config: dict[str, Any]) -> SwiftProModel:
    """The arm's kinematics for the profile's work mode."""
    return SwiftProModel(int(config.get("mode", 0)))


def emulator(config: dict[str, Any], clock: Clock, seed: int = 0) -> SwiftProEmulator:
    """Firmware V4.10's emulator (not started) on ``clock``."""
    return SwiftProEmulator(model(config), clock, seed=seed)


def uarm_swift_pro(config: dict[str, Any], context: RigContext) -> SwiftProDriver:
    """uFactory uArm Swift Pro (firmware 4.x G-code over USB serial); port: sim emulates it."""
    arm = model(config)
    port, options = driver_port(
        config, context, lambda: SwiftProEmulator(arm, context.clock, seed=context.seed)
    )
    return SwiftProDriver(
        arm,
        port,
        baud=int(config.get("baud", 115200)),
        max_feed=float(config.get("max_feed", 75.0)),
        link_timeout=float(config.get("link_timeout", 1.0)),
        **options,
    )


uarm_swift_pro.PARAMS = (
    armtree.Param(
        "port", "str", "sim", doc="serial device (/dev/ttyACM0), or sim for the emulator"
    ),
    armtree.Param("baud", "int", 115200, doc="serial speed (the firmware's 115200)", minimum=1200),
    armtree.Param(
        "mode",
        "int",
        0,
        doc="work mode: its end effector's offsets (0 suction cup, 3 pen holder, ...)",
        choices=tuple(MODES),
    ),
    armtree.Param(
        "max_feed",
        "float",
        75.0,
        doc="G0 F at full speed (one unit: 80 degrees of joint motion per minute)",
        exclusive_minimum=0,
        maximum=200,
    ),
    armtree.Param(
        "link_timeout",
        "float",
        1.0,
        unit="s",
        doc="silence after which the link is lost",
        minimum=0.1,
    ),
)
uarm_swift_pro.model = model
uarm_swift_pro.emulator = emulator
uarm_swift_pro.simulated = on_emulator
uarm_swift_pro.grips_with = lambda config: (
    "suction" if int(config.get("mode", 0)) in SUCTION_MODES else None
)


@armtree.hookimpl
def armtree_arms() -> dict[str, Any]:
    """Register ``uarm_swift_pro``."""
    return {"uarm_swift_pro": uarm_swift_pro}
