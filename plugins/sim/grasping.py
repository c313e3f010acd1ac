"""What a simulated end effector holds: a body picked up, carried and let go."""

from __future__ import annotations

import numpy as np

from .bodies import ArmView, Body
from .geometry import point_in_polygon, pose, rot_z
from .world_state import WorldState

#: Kinds an end effector can lift.
MOVABLE = ("ducky", "trash", "block")


class Grasp:
    """Suction and gripper physics of one world's arm.

    Each step (:meth:`step`, after the arm's true state is read): a held body
    follows the tool until the cup lets go or the jaws open; otherwise a cup that
    is on and within ``physics.pick_tolerance_mm`` of a movable body's top picks
    the highest one up, and jaws closing on a body centred between them grip it.
    What rested on a body picked up starts to fall. Picks and releases are world
    events.
    """

    def __init__(self, world: WorldState) -> None:
        self._world = world
        #: The name of the body held, or None.
        self.held: str | None = None
        self._held_rel: np.ndarray | None = None
        self._last_gripper: float | None = None
        self._mode = "suction"

    def step(self, now: float) -> None:
        """Carry, pick up or let go at run time ``now`` (s)."""
        world = self._world
        arm = world.arm
        if arm is None:
            return
        tip = arm.tool_pose[:3, 3]
        if self.held is not None:
            body = world.bodies[self.held]
            assert self._held_rel is not None
            body.pose = arm.tool_pose @ self._held_rel
            if not self._still_holding(arm, body):
                self._release(now)
        elif arm.suction:
            target = self._suction_target(tip)
            if target is not None:
                self._grab(target, arm, now, "suction")
        elif arm.gripper is not None:
            target = self._gripper_target(arm)
            if target is not None:
                self._grab(target, arm, now, "gripper")
        self._last_gripper = arm.gripper

    def _opening_mm(self, arm: ArmView) -> float | None:
        if arm.gripper is None:
            return None
        return float(arm.gripper) * self._world.physics.gripper_mm_per_unit

    def _still_holding(self, arm: ArmView, body: Body) -> bool:
        if self._mode == "suction":
            return arm.suction
        opening = self._opening_mm(arm)
        return opening is not None and opening <= min(body.size[:2]) + 1.0

    def _suction_target(self, tip: np.ndarray) -> Body | None:
        """The highest movable body whose top face is within the pick tolerance of the cup."""
        tol = self._world.physics.pick_tolerance_mm
        best = None
        for body in self._world.bodies.values():
            if body.kind not in MOVABLE or body.falling or body.held:
                continue
            if abs(tip[2] - body.top) > tol:
                continue
            if not point_in_polygon(tip[:2], body.footprint()):
                continue
            if best is None or body.top > best.top:
                best = body
        return best

    def _gripper_target(self, arm: ArmView) -> Body | None:
        """A movable body between the jaws when they close on it."""
        physics = self._world.physics
        opening = self._opening_mm(arm)
        if opening is None:
            return None
        was = (
            None if self._last_gripper is None else self._last_gripper * physics.gripper_mm_per_unit
        )
        # Jaws that are not closing grab nothing: closing_on_it below needs was > opening.
        if was is not None and was <= opening:
            return None
        tip = arm.tool_pose[:3, 3]
        for body in self._world.bodies.values():
            if body.kind not in MOVABLE or body.falling or body.held:
                continue
            width = float(min(body.size[:2]))
            closing_on_it = opening <= width + 1.0 and (was is None or was > width + 1.0)
            # The jaws reach a little below the tool centre: a grip from just above the top holds.
            inside = body.bottom - 1.0 <= tip[2] <= body.top + physics.pick_tolerance_mm
            centred = np.linalg.norm(tip[:2] - body.pose[:2, 3]) <= 0.25 * width
            if closing_on_it and inside and centred:
                return body
        return None

    def _grab(self, body: Body, arm: ArmView, now: float, mode: str) -> None:
        self.held = body.name
        self._mode = mode
        body.held, body.falling, body.vz, body.support = True, False, 0.0, None
        self._held_rel = np.linalg.inv(arm.tool_pose) @ body.pose
        for other in self._world.bodies.values():
            if other.support == body.name:
                other.support, other.falling, other.vz = None, True, 0.0
                other.fall_from = other.bottom
        self._world.event(now, "pick", {"object": body.name, "by": mode})

    def _release(self, now: float) -> None:
        assert self.held is not None
        body = self._world.bodies[self.held]
        # A released object hangs level: keep only its heading and position.
        body.pose = pose(rot_z(body.yaw), body.pose[:3, 3])
        body.held, body.falling, body.vz = False, True, 0.0
        body.fall_from = body.bottom
        self.held, self._held_rel = None, None
        self._world.event(
            now, "release", {"object": body.name, "at": body.pose[:3, 3].round(2).tolist()}
        )
