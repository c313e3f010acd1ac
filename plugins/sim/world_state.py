"""What the world's helpers (gravity, grasping, contacts, scoring) read of the world.

The helpers are parts of :class:`~.world.World` and are handed it; typing them
against this protocol keeps them from importing the module that builds them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from .bodies import ArmView, Body, WorldEvent
from .duckybot import Duckybot
from .physics import CollisionMonitor
from .scene_spec import PhysicsSpec, TableSpec


class WorldState(Protocol):
    """The simulated world as its helpers see it (mm, seconds of run time)."""

    time: float
    table: TableSpec
    physics: PhysicsSpec
    bodies: dict[str, Body]
    duckybots: dict[str, Duckybot]
    arm: ArmView | None
    emulator: Any
    collisions: CollisionMonitor
    events: list[WorldEvent]
    on_halt: Callable[[str], None] | None

    @property
    def held(self) -> str | None:
        """The name of the body the end effector holds, or None."""
        ...

    def event(self, now: float, kind: str, detail: dict[str, Any]) -> None:
        """Record an event at run time ``now`` and tell the listeners."""
        ...

    def in_bin(self, body: Body) -> str | None:
        """The container ``body`` lies in, or None."""
        ...

    def carried_by(self, name: str, kinds: tuple[str, ...] | None = None) -> list[Body]:
        """The bodies resting on ``name`` (of ``kinds`` when given)."""
        ...
