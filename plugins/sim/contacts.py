"""Collisions in the simulated world: the arm (and what it holds) against the bodies."""

from __future__ import annotations

import dataclasses

from .geometry import obb_penetration
from .physics import CollisionMonitor, SolidBox, clearly_apart
from .world_state import WorldState


class ArmContacts:
    """Finds where one world's arm hits something, each step.

    The arm's link boxes and the held body are checked against the bodies
    (:class:`~.physics.CollisionMonitor` reports each new contact deeper than the
    tolerance once), the tool against the table top, and the held body against
    what lies under the tool. Each new collision is a world event; under
    ``physics.halt_on_collision`` the emulated arm halts and the run is told.
    """

    def __init__(self, world: WorldState) -> None:
        self._world = world
        self._inputs_checked: bytes | None = None

    def start_overlaps(self) -> list[tuple[str, str]]:
        """(link, body) pairs that interpenetrate now: a world placing bodies inside the arm."""
        world = self._world
        if world.arm is None:
            return []
        links, others = self._solids()
        probe = CollisionMonitor(world.collisions.tolerance)
        return [(hit.link, hit.other) for hit in probe.update(world.time, links, others)]

    def check(self, now: float) -> None:
        """Record the collisions at run time ``now`` (s), halting the arm if the world says so."""
        world = self._world
        arm = world.arm
        if arm is None:
            return
        inputs = self._inputs()
        if inputs == self._inputs_checked:
            # Nothing moved since the last check: the same contacts, none of them new.
            return
        self._inputs_checked = inputs
        links, others = self._solids()
        extra = {("tool", "table"): float(world.table.height - arm.tool_pose[2, 3])}
        extra.update(self._held_contacts({solid.name for solid in others}))
        fresh = world.collisions.update(now, links, others, extra)
        for hit in fresh:
            world.event(now, "collision", dataclasses.asdict(hit))
            if world.physics.halt_on_collision and world.emulator is not None:
                reason = f"collision: {hit.link} hit {hit.other} ({hit.depth_mm:.1f} mm deep)"
                world.emulator.halt(reason)
                if world.on_halt is not None:
                    world.on_halt(reason)

    def _solids(self) -> tuple[list[SolidBox], list[SolidBox]]:
        """The arm's boxes (and what it holds), and the bodies they could hit."""
        world = self._world
        arm = world.arm
        assert arm is not None
        links = [
            SolidBox(n, p, s)
            for n, p, s in zip(arm.box_names, arm.box_poses, arm.box_sizes, strict=True)
        ]
        if world.held is not None:
            held = world.bodies[world.held]
            links += [SolidBox(f"held {held.name}", held.center_pose(), held.size)]
        tip = arm.tool_pose[:3, 3]
        tol = world.physics.pick_tolerance_mm
        # The tool centre (suction cup, gripper tips) is the lowest point of an end
        # effector: a body whose top is below it is touched at most, never hit, even
        # where a model's link box reaches lower than the tool centre.
        others = [
            solid
            for b in world.bodies.values()
            if not b.held and b.top > tip[2] + tol
            for solid in b.solids()
        ]
        return links, others

    def _held_contacts(self, checked: set[str]) -> dict[tuple[str, str], float]:
        """Depths (mm) of the held body in the bodies :meth:`_solids` leaves out.

        The tool centre's exemption is the end effector's: what it holds hangs
        below it and is pressed into a body under the tool as any link would be.
        """
        world = self._world
        if world.held is None:
            return {}
        held = world.bodies[world.held]
        box = SolidBox(f"held {held.name}", held.center_pose(), held.size)
        out: dict[tuple[str, str], float] = {}
        for body in world.bodies.values():
            if body.held or body.name in checked:
                continue
            for solid in body.solids():
                # most bodies lie far from what the arm holds: the cheap test finds them
                # 0 mm deep, as the exact one would
                if clearly_apart(box, solid):
                    depth = 0.0
                else:
                    depth = obb_penetration(box.pose, box.size, solid.pose, solid.size)
                key = (box.name, solid.name)
                out[key] = max(out.get(key, 0.0), float(depth))
        return out

    def _inputs(self) -> bytes:
        """Everything a collision check reads: the arm's boxes and tool, what it holds, the bodies."""
        world = self._world
        arm = world.arm
        assert arm is not None
        parts = [arm.box_poses.tobytes(), arm.tool_pose.tobytes(), str(world.held).encode()]
        for body in world.bodies.values():
            parts += [body.pose.tobytes(), body.size.tobytes(), b"H" if body.held else b"-"]
        return b"".join(parts)
