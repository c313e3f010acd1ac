"""Gravity in the simulated world: what a body rests on, and bodies falling onto it."""

from __future__ import annotations

from .bodies import Body
from .geometry import point_in_polygon
from .world_state import WorldState

#: Gravity, mm/s^2.
GRAVITY = 9810.0
#: Where an object that falls off the table ends up, below the table top (mm).
FLOOR_DROP = 750.0
#: A fall longer than this (mm) outside a bin is a drop: a place let go too high.
DROP_MM = 15.0


class Gravity:
    """Supports and falls of one world's bodies.

    :meth:`support_below` finds the surface under a body (a bin's floor inside
    its walls, another body's top, the table, or the floor off the table);
    :meth:`fall` moves falling bodies down at ``GRAVITY`` until they land, as
    ``land`` events, and a fall longer than ``DROP_MM`` outside a bin (or off the
    table) as a ``drop`` too.
    """

    def __init__(self, world: WorldState) -> None:
        self._world = world

    def support_below(self, body: Body) -> tuple[str, float]:
        """The surface under the body's centre: (name, height mm); the table at least.

        A surface up to the collision tolerance above the body's bottom still
        counts (it is raised onto it): contacts that shallow are not collisions,
        so a body let go that shallowly inside another rests on it.
        """
        world = self._world
        centre = body.pose[:2, 3]
        slack = world.physics.collision_tolerance_mm
        if not point_in_polygon(centre, world.table.polygon()):
            return "floor", world.table.height - FLOOR_DROP
        best_name, best_z = "table", world.table.height
        for other in world.bodies.values():
            if other is body or other.held or other.kind == "spot" or other.falling:
                continue
            if other.support == body.name:
                continue
            if other.kind == "bin":
                inner = other.footprint(shrink=other.spec.wall)
                z = other.bottom + other.spec.wall if point_in_polygon(centre, inner) else other.top
            else:
                z = other.top
            if (
                z > best_z
                and z <= body.bottom + slack + 1e-6
                and point_in_polygon(centre, other.footprint())
            ):
                best_name, best_z = other.name, z
        return best_name, best_z

    def fall(self, dt: float, now: float) -> None:
        """Move every falling body ``dt`` s further down; land those that reach a surface."""
        world = self._world
        for body in world.bodies.values():
            if not body.falling:
                continue
            name, z = self.support_below(body)
            body.vz += GRAVITY * dt
            new_bottom = body.bottom - body.vz * dt
            if new_bottom <= z:
                body.pose[2, 3] = z
                body.falling, body.vz, body.support = False, 0.0, name
                body.off_table = name == "floor"
                fall = round(body.fall_from - z, 2)
                world.event(now, "land", {"object": body.name, "on": name, "fall_mm": fall})
                if body.off_table or (fall > DROP_MM and world.in_bin(body) is None):
                    world.event(now, "drop", {"object": body.name, "on": name, "fall_mm": fall})
            else:
                body.pose[2, 3] = new_bottom
