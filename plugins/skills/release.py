"""Letting go: approach over a point, descend, open the tool, lift back.

Shared by ``place``, ``release`` and the clean-up's trash drops. A release point just
out of reach gives way to the nearest reachable one nearby. Tool centre, base frame, mm.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from armtree.api.rig import needed
from armtree.api.skill.actions import Grip, Move, Pause
from armtree.api.skill.arm import UP, ArmSkill, above
from armtree.api.skill.base import Procedure
from armtree.api.skill.reach import nearest_reachable, reachable

#: How far a release point may move to within reach (mm), and how much lower at most.
RELEASE_SLACK_MM = 15.0
RELEASE_DROP_MM = 3.0


def release_steps(
    skill: ArmSkill,
    target: np.ndarray,
    approach: float,
    release: float,
    dwell: float,
    check: Callable[[np.ndarray], Procedure] | None = None,
) -> Procedure:
    """Approach above ``target``, descend to ``release`` mm above it, open the tool, lift back
    (``check``: as :func:`release_at`'s).

    A release point just out of reach (a Duckybot parked at the edge of a small
    workspace) gives way to the nearest reachable one within
    :data:`RELEASE_SLACK_MM`, no lower than :data:`RELEASE_DROP_MM` under it.
    """
    point = target + UP * release
    model = needed(skill.rig.arm, "arm").model
    if not reachable(model, point):
        near = nearest_reachable(
            model, point, span=2 * RELEASE_SLACK_MM, min_z=point[2] - RELEASE_DROP_MM
        )
        if near is not None and np.linalg.norm(near - point) <= RELEASE_SLACK_MM:
            point = near
    return (yield from release_at(skill, point, max(0.0, approach - release), dwell, check))


def release_at(
    skill: ArmSkill,
    point: np.ndarray,
    approach: float,
    dwell: float,
    check: Callable[[np.ndarray], Procedure] | None = None,
) -> Procedure:
    """Approach ``approach`` mm above ``point`` (as much as reachable), descend to it, open
    the tool, lift back. Returns the point let go at: ``check(point)``, when given, runs
    at the approach and returns the point to descend to instead (a correction)."""
    rig, speed = skill.rig, skill.speed()
    over = above(skill, point, approach)
    yield Move(rig, over, speed=speed, label="approach")
    if check is not None:
        point = yield from check(point)
        over = np.array([point[0], point[1], max(over[2], point[2])])
    if over[2] > point[2] + 1e-6:
        yield Move(rig, point, speed=speed, label="descend")
    yield Grip(rig, False)
    yield Pause(skill.clock, dwell)
    if over[2] > point[2] + 1e-6:
        yield Move(rig, over, speed=speed, label="lift")
    return point


__all__ = ["RELEASE_DROP_MM", "RELEASE_SLACK_MM", "release_at", "release_steps"]
