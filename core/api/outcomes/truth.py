"""What a world really looks like, as the predicates of ``expect:`` read it.

A plugin that knows the ground truth (the built-in simulation) hands a
:class:`WorldTruth` to the runtime through ``armtree_ground_truth(run)`` at the
end of a run, and the nominal world's through ``armtree_world_inventory(profile)``
while a tree loads, so names in ``expect:`` are checked before anything moves.
Without such a plugin (real hardware) the inventory is made from the profile's
tag roles and places, and expectations are reported as not checked.

Millimetres and degrees in the robot's base frame (z up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class WorldObject:
    """One body of the world.

    ``position`` is the centre of its bottom face (mm); ``on`` what it rests on
    (a body's name, ``"table"`` or ``"floor"``; None while held or falling);
    ``inside`` the container (a bin) it lies in, if any; ``container`` says
    that things can be put in it.
    """

    name: str
    kind: str
    role: str | None = None
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw_deg: float = 0.0
    on: str | None = "table"
    inside: str | None = None
    held: bool = False
    container: bool = False

    def distance_xy(self, point: tuple[float, ...]) -> float:
        """Distance in the table plane from the body's centre to ``point`` (mm)."""
        return math.hypot(self.position[0] - point[0], self.position[1] - point[1])


#: ``WorldTruth.extra`` keys a ground-truth plugin fills for ``parked`` and
#: ``tool_within_mm``: each Duckybot's ``phase`` and ``pose`` [x, y, heading] by name,
#: the tool centre, and each marked body's marker centre by name (mm, degrees).
DUCKYBOTS, TOOL, MARKERS = "duckybots", "tool_mm", "markers"


@dataclass
class WorldTruth:
    """A world's bodies, places and what happened in it.

    ``objects`` by name; ``roles`` maps a tag role to the names of the bodies
    carrying it (a role may have none, as on real hardware); ``places`` are the
    profile's named points (mm); ``held`` the body the tool holds; the event
    lists hold one mapping per collision (``link``, ``other``, ``depth_mm``,
    ``time``), missed step and drop. ``complete`` is False for an inventory made
    from names only (a real rig), where a name cannot be checked for its kind.
    ``extra`` holds what the built-in ``parked`` and ``tool_within_mm`` read
    (:data:`DUCKYBOTS`, :data:`TOOL`, :data:`MARKERS`; without them those judge
    "not known") and is free for plugins' own predicates.
    """

    objects: dict[str, WorldObject] = field(default_factory=dict)
    roles: dict[str, list[str]] = field(default_factory=dict)
    places: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    held: str | None = None
    collisions: list[dict[str, Any]] = field(default_factory=list)
    missed_steps: list[dict[str, Any]] = field(default_factory=list)
    drops: list[dict[str, Any]] = field(default_factory=list)
    complete: bool = True
    extra: dict[str, Any] = field(default_factory=dict)

    def knows(self, ref: str) -> bool:
        """True when ``ref`` names a body or a tag role of this world."""
        return ref in self.objects or ref in self.roles

    def select(self, ref: str) -> list[WorldObject]:
        """The body named ``ref``, or every body of the tag role ``ref`` (by name)."""
        if ref in self.objects:
            return [self.objects[ref]]
        return [self.objects[n] for n in sorted(self.roles.get(ref, ())) if n in self.objects]

    def names(self) -> list[str]:
        """Every body name and role, sorted (for did-you-mean hints)."""
        return sorted(set(self.objects) | set(self.roles))

    def supports(self, obj: WorldObject) -> list[str]:
        """What ``obj`` rests on, then what that rests on, down to the table (names)."""
        chain: list[str] = []
        current = obj.on
        while current is not None and current not in chain:
            chain.append(current)
            below = self.objects.get(current)
            current = below.on if below is not None else None
        return chain
