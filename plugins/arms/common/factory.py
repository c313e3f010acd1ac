"""What an arm plugin's factory carries besides the call: the members the loader and
the tools (``armtree check``, the sim, ``calibrate``, jog) read off it.

A plugin sets them on its factory function; mypy types a ``def`` as a plain callable,
which has no attributes to set, so each plugin casts its factory to
:class:`ArmFactory` (or a Protocol extending it) once: the same function, typed as
what it is once its members are set.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, TypeVar

from armtree.api.component_factory import ComponentFactory

ModelT = TypeVar("ModelT")
EmulatorT = TypeVar("EmulatorT")
DriverT_co = TypeVar("DriverT_co", covariant=True)


class ArmFactory(ComponentFactory[DriverT_co], Protocol[ModelT, EmulatorT, DriverT_co]):
    """An arm factory: ``factory(config, context)`` builds the driver; ``PARAMS`` its
    parameters, ``model(config)`` its kinematic model, ``simulated(config)`` whether it
    runs on the emulator, ``emulator(config, clock, seed=0)`` that emulator (not
    started), ``grips_with(config)`` the tool it grips with (None: it cannot grip)."""

    model: Callable[[dict[str, Any]], ModelT]
    simulated: Callable[[dict[str, Any]], bool]
    emulator: Callable[..., EmulatorT]  # (config, clock, seed=0)
    grips_with: Callable[[dict[str, Any]], str | None]


__all__ = ["ArmFactory"]
