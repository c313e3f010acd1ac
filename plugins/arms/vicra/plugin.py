"""Registration of the built-in vicra plugin: ``arm: {type: vicra}``."""

from __future__ import annotations

from typing import Any, cast

import armtree
from armtree.api.clock import Clock
from armtree.api.rig import RigContext
from armtree.config.params import Param
from armtree.errors import ConfigError
from armtree.plugins.arms.common import driver_port, on_emulator
from armtree.plugins.arms.common.factory import ArmFactory

from .driver import VicraDriver
from .emulator import MarlinEmulator
from .kinematics import VicraModel


def _model(config: dict[str, Any]) -> VicraModel:
    """The VICRA's kinematic model from a profile's ``arm`` mapping."""
    links = config.get("links_mm", [300.0, 300.0])
    if not isinstance(links, (list, tuple)) or len(links) != 2 or min(links) <= 0:
        raise ConfigError(f"arm.links_mm must be two positive lengths, got {links!r}")
    travel = config.get("z_travel_mm", 600.0)
    return VicraModel(float(links[0]), float(links[1]), float(travel))


def _emulator(config: dict[str, Any], clock: Clock, seed: int = 0) -> MarlinEmulator:
    """The VICRA's Marlin firmware emulator (not started) on ``clock``."""
    return MarlinEmulator(_model(config), clock, seed=seed)


_VicraFactory = ArmFactory[VicraModel, MarlinEmulator, VicraDriver]


def vicra_factory(config: dict[str, Any], context: RigContext) -> VicraDriver:
    """VICRA SCARA arm on Marlin G-code (Mega + RAMPS); ``port: sim`` for the emulator."""
    model = _model(config)
    tool = config.get("tool", "gripper")
    if tool not in ("gripper", "suction"):
        raise ConfigError(f"arm.tool must be gripper or suction, got {tool!r}")
    port, options = driver_port(
        config, context, lambda: MarlinEmulator(model, context.clock, seed=context.seed)
    )
    return VicraDriver(
        model,
        port,
        baud=int(config.get("baud", 115200)),
        link_timeout=float(config.get("link_timeout", 5.0)),
        home_on_connect=bool(config.get("home_on_connect", True)),
        tool=tool,
        feed=float(config.get("feed", 6000.0)),
        **options,
    )


# mypy types a def as a plain callable, which has no attributes to set: the same function,
# typed as what it is once the members below are set.
vicra_factory = cast(_VicraFactory, vicra_factory)
vicra_factory.PARAMS = (
    Param("port", "str", "sim", doc="serial device, or sim for the built-in Marlin emulator"),
    Param(
        "baud", "int", 115200, doc="serial speed (Marlin's BAUDRATE)", minimum=0, maximum=4_000_000
    ),
    Param(
        "links_mm",
        "vector",
        [300.0, 300.0],
        unit="mm",
        doc="shoulder and elbow link lengths",
        exclusive_minimum=0.0,
        maximum=5000.0,
        length=2,
    ),
    Param(
        "z_travel_mm",
        "float",
        600.0,
        unit="mm",
        doc="travel of the vertical column",
        exclusive_minimum=0.0,
        maximum=5000.0,
    ),
    Param(
        "tool",
        "str",
        "gripper",
        doc="gripper (servo 1) or suction (pump on the fan output)",
        choices=("gripper", "suction"),
    ),
    Param("home_on_connect", "bool", True, doc="run G28 as soon as the link is up"),
    Param(
        "feed",
        "float",
        6000.0,
        unit="units/min",
        doc="G1 feed rate at full speed",
        exclusive_minimum=0.0,
        maximum=1_000_000.0,
    ),
    Param(
        "link_timeout",
        "float",
        5.0,
        unit="s",
        doc="silence after which the link is lost",
        minimum=0.05,
        maximum=600.0,
    ),
)
vicra_factory.model = _model
vicra_factory.simulated = on_emulator
vicra_factory.emulator = _emulator
#: What the skills grip with (set_suction): the pump or the gripper, as configured.
vicra_factory.grips_with = lambda config: str(config.get("tool", "gripper"))


@armtree.hookimpl
def armtree_arms() -> dict[str, Any]:
    """Register ``vicra``."""
    return {"vicra": vicra_factory}
