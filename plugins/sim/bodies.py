"""The simulated world's plain data: a body's state, the arm as the world sees it, an event.

:class:`Body` is one object's pose and support (with its collision solids),
:class:`ArmView` the arm's joints, tool and link boxes at the latest step, and
:class:`WorldEvent` one thing that happened (a pick, a drop, a collision).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .geometry import pose
from .physics import SolidBox
from .scene_spec import MarkerSpec, ObjectSpec


@dataclass
class Body:
    """An object's state: ``pose`` is the 4x4 pose of its bottom-face centre (mm)."""

    spec: ObjectSpec
    pose: np.ndarray
    support: str | None = "table"
    held: bool = False
    falling: bool = False
    vz: float = 0.0
    off_table: bool = False
    #: Height of its bottom (mm) when it started to fall.
    fall_from: float = 0.0
    #: :meth:`solids` as last built, and the pose and size it was built for.
    _solids_memo: tuple[bytes, list[SolidBox]] | None = field(
        default=None, repr=False, compare=False
    )

    @property
    def name(self) -> str:
        """The name given in the profile."""
        return self.spec.name

    @property
    def kind(self) -> str:
        """ducky, trash, obstacle, bin, spot or duckybot."""
        return self.spec.kind

    @property
    def size(self) -> np.ndarray:
        """(x, y, z) extents, mm."""
        return self.spec.size

    @property
    def marker(self) -> MarkerSpec | None:
        """The marker on its top face, if any."""
        return self.spec.marker

    @property
    def bottom(self) -> float:
        """Height of its lowest point, mm (bodies are kept level except while held)."""
        return float(self.pose[2, 3])

    @property
    def top(self) -> float:
        """Height of its top face, mm."""
        return float(self.pose[2, 3] + self.size[2])

    @property
    def yaw(self) -> float:
        """Heading about z, radians."""
        return math.atan2(self.pose[1, 0], self.pose[0, 0])

    def center_pose(self) -> np.ndarray:
        """4x4 pose of the body's centre."""
        return self.pose @ pose(np.eye(3), [0.0, 0.0, 0.5 * self.size[2]])

    def top_pose(self) -> np.ndarray:
        """4x4 pose of the top-face centre: the marker frame (x, y in the face, z up)."""
        return self.pose @ pose(np.eye(3), [0.0, 0.0, self.size[2]])

    def footprint(self, shrink: float = 0.0) -> np.ndarray:
        """Footprint corners (4, 2) in the table plane, optionally shrunk by ``shrink`` mm."""
        hx, hy = 0.5 * self.size[0] - shrink, 0.5 * self.size[1] - shrink
        local = np.array([[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0]], dtype=float)
        return (local @ self.pose[:3, :3].T + self.pose[:3, 3])[:, :2]

    def solids(self) -> list[SolidBox]:
        """Collision boxes: one for a solid, five (floor and walls) for a bin, none for a spot."""
        # Rebuilt only when the pose or size changed: most bodies rest for most of a run.
        key = self.pose.tobytes() + self.size.tobytes()
        if self._solids_memo is None or self._solids_memo[0] != key:
            self._solids_memo = (key, self._build_solids())
        return list(self._solids_memo[1])

    def _build_solids(self) -> list[SolidBox]:
        if self.kind == "spot":
            return []
        if self.kind != "bin":
            return [SolidBox(self.name, self.center_pose(), self.size)]
        sx, sy, sz = self.size
        w = self.spec.wall
        parts = [
            ((0, 0, w / 2), (sx, sy, w)),
            ((sx / 2 - w / 2, 0, sz / 2), (w, sy, sz)),
            ((-sx / 2 + w / 2, 0, sz / 2), (w, sy, sz)),
            ((0, sy / 2 - w / 2, sz / 2), (sx, w, sz)),
            ((0, -sy / 2 + w / 2, sz / 2), (sx, w, sz)),
        ]
        return [SolidBox(self.name, self.pose @ pose(np.eye(3), c), np.array(s)) for c, s in parts]


@dataclass
class ArmView:
    """The arm as the world sees it at one instant: joints, tool pose, link boxes."""

    joints: np.ndarray
    tool_pose: np.ndarray
    box_poses: np.ndarray
    box_sizes: np.ndarray
    box_names: tuple[str, ...]
    suction: bool = False
    gripper: float | None = None


@dataclass
class WorldEvent:
    """Something that happened, for the run summary: pick, release, land, collision."""

    time: float
    kind: str
    detail: dict[str, Any] = field(default_factory=dict)


__all__ = ["ArmView", "Body", "WorldEvent"]
