"""Whether the tool, lowered to grip, would hit the objects the camera saw beside the target.

A grip lowers the tool's boxes (the gripper's open jaws, a suction cup's body) to
the object's height; an object standing next to it within the boxes' reach is hit on
the way down. Only what the rig senses is used: the markers the camera saw near the
target (its last frames), each standing on the table as a square as wide as its
marker plus :data:`OBJECT_MARGIN_MM` (the object is at least as wide as the marker
printed on it), turned as its marker, up to the height the profile gives its role
(``workcell.marker_heights_mm``; else the marker's measured height), and the arm's
own link boxes at the joints the grip point asks for. A grip that would hit moves
within what still holds the object (:func:`clear_grip`), or is refused.
Positions in the base frame, mm.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from armtree.api.skill.arm import ArmSkill
from armtree.api.skill.eye import eye_of
from armtree.maths.motion.collision import obb_overlap

#: A marker's object reaches this far beyond the marker's edges (mm): printed markers
#: sit on objects a little wider than themselves.
OBJECT_MARGIN_MM = 4.0
#: Growth of the tool's boxes (mm): slack for how far a measured position is off.
TOOL_MARGIN_MM = 1.0
#: Markers farther than this (mm, horizontally) from the grip are not looked at.
NEAR_MM = 150.0
#: Markers last seen longer ago than this (s, run clock) are not trusted to be there.
MEMORY_S = 30.0
#: Steps (mm) and directions of the shifted grips tried.
SHIFT_STEP_MM = 1.0
SHIFT_DIRECTIONS = 16


@dataclass(frozen=True)
class Neighbour:
    """An object the camera saw: its marker, and the box it fills (centre, rotation, half size, mm)."""

    role: str
    id: int
    centre: np.ndarray
    rotation: np.ndarray
    half: np.ndarray

    @property
    def top(self) -> float:
        """Height (mm) of the object's top."""
        return float(self.centre[2] + self.half[2])


def neighbours(skill: ArmSkill, target: np.ndarray, marker: int | None) -> list[Neighbour]:
    """The objects whose markers the camera saw within :data:`NEAR_MM` of ``target``
    (mm) in the last :data:`MEMORY_S` seconds, other than marker ``marker`` (the one
    gripped), the tool's own (``workcell.tool_marker``) and those gripped away or
    last seen carried off the table."""
    eye = eye_of(skill.rig)
    now = skill.rig.clock.now()
    cell = skill.workcell
    table = cell.table_z_mm
    tool = cell.tool_marker.tag if cell.tool_marker is not None else None
    out = []
    for seen in eye.seen.values():
        if seen.id == marker or seen.role == tool or now - eye.seen_at[seen.id] > MEMORY_S:
            continue
        where = seen.position
        if np.hypot(*(where[:2] - target[:2])) > NEAR_MM:
            continue
        spec = skill.rig.tags.get(seen.role)
        width = spec.size_mm if spec is not None else 0.0
        height = cell.marker_heights_mm.get(seen.role)
        top = float(where[2]) if height is None or table is None else table + height
        bottom = table if table is not None else top - 1000.0
        if top <= bottom:
            continue
        yaw = float(np.arctan2(seen.pose[1, 0], seen.pose[0, 0]))
        c, s = np.cos(yaw), np.sin(yaw)
        out.append(
            Neighbour(
                seen.role,
                seen.id,
                np.array([where[0], where[1], 0.5 * (top + bottom)]),
                np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]),
                np.array(
                    [0.5 * width + OBJECT_MARGIN_MM] * 2 + [0.5 * (top - bottom)], dtype=float
                ),
            )
        )
    return out


def hit_by(model: Any, q: np.ndarray, objects: list[Neighbour]) -> list[Neighbour]:
    """The objects that the arm's link boxes, at joints ``q`` and grown by
    :data:`TOOL_MARGIN_MM`, overlap."""
    if not model.boxes or not objects:
        return []
    poses = model.box_poses(np.asarray(q, dtype=float))
    half = 0.5 * model.box_sizes() + TOOL_MARGIN_MM
    hits = []
    for obj in objects:
        overlap = obb_overlap(
            poses[:, :3, 3], poses[:, :3, :3], half, obj.centre, obj.rotation, obj.half
        )
        if np.any(overlap):
            hits.append(obj)
    return hits


@dataclass(frozen=True)
class Clearance:
    """Where to grip: ``grip`` (mm), how far it moved from the asked one, and what the
    asked one would have hit (empty: nothing)."""

    grip: np.ndarray | None
    shift_mm: float
    blocked_by: list[Neighbour]


def clear_grip(
    model: Any, grip: np.ndarray, near: np.ndarray, objects: list[Neighbour], hold_mm: float
) -> Clearance:
    """``grip`` (mm, the tool centre), or the nearest point up to ``hold_mm`` beside it
    (still holding the object) whose joints (IK nearest ``near``) keep the arm's boxes
    clear of ``objects``; ``grip`` None when no such point is reachable."""
    grip = np.asarray(grip, dtype=float)

    def hits(point: np.ndarray) -> list[Neighbour] | None:
        try:
            q = model.ik(point, near=near)
        except ValueError:  # out of reach (Unreachable)
            return None
        return hit_by(model, q, objects)

    first = hits(grip)
    if first is not None and not first:
        return Clearance(grip, 0.0, [])
    blocked = first or []
    angles = np.linspace(0.0, 2 * np.pi, SHIFT_DIRECTIONS, endpoint=False)
    ring = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=-1)
    if blocked:  # straight away from what it would hit first
        away = grip - np.mean([o.centre for o in blocked], axis=0)
        ring = ring[np.argsort(-(ring[:, :2] @ away[:2]), kind="stable")]
    for step in np.arange(SHIFT_STEP_MM, hold_mm + 1e-9, SHIFT_STEP_MM):
        for direction in ring:
            point = grip + direction * step
            found = hits(point)
            if found is not None and not found:
                return Clearance(point, float(step), blocked)
    return Clearance(None, 0.0, blocked)


__all__ = [
    "MEMORY_S",
    "NEAR_MM",
    "OBJECT_MARGIN_MM",
    "Clearance",
    "Neighbour",
    "clear_grip",
    "hit_by",
    "neighbours",
]
