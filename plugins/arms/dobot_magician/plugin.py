"""Registration of the built-in dobot_magician plugin: ``arm: {type: dobot_magician}``."""

from __future__ import annotations

from typing import Any, cast

import armtree
from armtree.api.clock import Clock
from armtree.api.rig import RigContext
from armtree.config.params import Param
from armtree.errors import ConfigError
from armtree.plugins.arms.common import driver_port, on_emulator
from armtree.plugins.arms.common.factory import ArmFactory

from .driver import MagicianDriver
from .emulator import MagicianEmulator
from .kinematics import MagicianModel


def _model(config: dict[str, Any]) -> MagicianModel:
    """The Magician's kinematic model from a profile's ``arm`` mapping."""
    links = config.get("links_mm", [135.0, 147.0])
    tool = config.get("tool_offset_mm", [59.7, 0.0, 0.0])
    if isinstance(tool, (int, float)) and not isinstance(tool, bool):
        tool = [float(tool), 0.0, 0.0]
    if not _numbers(tool, 3):
        raise ConfigError(f"arm.tool_offset_mm: expected [x, y, z] in mm, got {tool!r}")
    if not _numbers(links, 2):
        raise ConfigError(f"arm.links_mm: expected [rear arm, forearm] in mm, got {links!r}")
    return MagicianModel(links[0], links[1], tool)


def _numbers(value: Any, n: int) -> bool:
    return (
        isinstance(value, (list, tuple))
        and len(value) == n
        and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and abs(v) < 1e4 for v in value
        )
    )


def _emulator(config: dict[str, Any], clock: Clock, seed: int = 0) -> MagicianEmulator:
    """The Magician firmware emulator (not started) on ``clock``."""
    return MagicianEmulator(_model(config), clock, seed=seed)


_MagicianFactory = ArmFactory[MagicianModel, MagicianEmulator, MagicianDriver]


def magician_factory(config: dict[str, Any], context: RigContext) -> MagicianDriver:
    """Dobot Magician over its 0xAA 0xAA serial protocol (``port: sim`` for the emulator)."""
    model = _model(config)
    port, options = driver_port(
        config, context, lambda: MagicianEmulator(model, context.clock, seed=context.seed)
    )
    return MagicianDriver(
        model,
        port,
        baud=int(config.get("baud", 115200)),
        link_timeout=float(config.get("link_timeout", 1.0)),
        **options,
    )


# mypy types a def as a plain callable, which has no attributes to set: the same function,
# typed as what it is once the members below are set.
magician_factory = cast(_MagicianFactory, magician_factory)
magician_factory.PARAMS = (
    Param("port", "str", "sim", doc="serial device, or sim for the built-in emulator"),
    Param(
        "baud",
        "int",
        115200,
        doc="serial speed (the Magician uses 115200)",
        minimum=0,
        maximum=4_000_000,
    ),
    Param(
        "links_mm",
        "vector",
        [135.0, 147.0],
        unit="mm",
        doc="rear arm and forearm lengths",
        exclusive_minimum=0.0,
        maximum=5000.0,
        length=2,
    ),
    Param(
        "tool_offset_mm",
        "any",
        [59.7, 0.0, 0.0],
        unit="mm",
        doc="end-effector offset from the wrist: forward, sideways, down",
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
)
magician_factory.model = _model
magician_factory.simulated = on_emulator
magician_factory.emulator = _emulator
#: What the skills grip with (set_suction): the suction cup.
magician_factory.grips_with = lambda config: "suction"


@armtree.hookimpl
def armtree_arms() -> dict[str, Any]:
    """Register ``dobot_magician``."""
    return {"dobot_magician": magician_factory}
