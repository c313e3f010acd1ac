"""What a profile's ``world:`` section describes, once checked: the scene's plain data.

:class:`SceneSpec` holds the table, the bodies (:class:`ObjectSpec` with their
:class:`MarkerSpec`), the Duckybots, faults, physics and light, in millimetres
and the robot's base frame (yaw in radians); ``scene.parse_scene`` builds it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .as_built import AsBuilt
from .duckybot import DuckybotParams, RouteSpec
from .geometry import rot_z


@dataclass(frozen=True)
class MarkerSpec:
    """A printed marker on a top face: family (``aruco`` or ``hamming``, the generator
    that draws it), dictionary (aruco), id, side (mm) and the tag role it is in ``tags:``."""

    family: str
    id: int
    size_mm: float
    dictionary: str = "4x4_50"
    role: str | None = None


@dataclass
class ObjectSpec:
    """One object as the profile places it.

    ``size`` is (x, y, z) extents in mm (a cylinder's x and y are its diameter);
    ``position`` is the centre of its bottom face; ``yaw`` is radians.
    """

    name: str
    kind: str
    shape: str
    size: np.ndarray
    position: np.ndarray
    yaw: float
    color: tuple[int, int, int]
    marker: MarkerSpec | None
    wall: float = 0.0

    def footprint(self) -> np.ndarray:
        """Corners (4, 2) of the footprint in the table plane, counter-clockwise."""
        hx, hy = 0.5 * self.size[0], 0.5 * self.size[1]
        local = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
        return local @ rot_z(self.yaw)[:2, :2].T + self.position[:2]


@dataclass
class DuckybotSpec:
    """A Duckybot: its body, marker, route and controller parameters."""

    body: ObjectSpec
    route: RouteSpec
    params: DuckybotParams


@dataclass
class TableSpec:
    """The table top: x and y ranges (mm), height of its surface (mm), texture."""

    x: tuple[float, float] = (-250.0, 450.0)
    y: tuple[float, float] = (-400.0, 400.0)
    height: float = 0.0
    texture: str = "wood"

    def polygon(self) -> np.ndarray:
        """Table outline (4, 2), counter-clockwise."""
        (x0, x1), (y0, y1) = self.x, self.y
        return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)


@dataclass
class PhysicsSpec:
    """Tool and collision physics options (mm)."""

    pick_tolerance_mm: float = 5.0
    collision_tolerance_mm: float = 3.0
    halt_on_collision: bool = True
    gripper_mm_per_unit: float = 1.0


@dataclass(frozen=True)
class SlipSpec:
    """Missed steps under load (Durovic 2017 and Showers 2016): a random joint slips now and then.

    While the arm moves or holds something, slips come at ``rate`` per second,
    each by up to ``max_amount`` degrees (or mm) either way, on one of ``joints``
    (all joints when empty). The emulator keeps reporting the commanded angle.
    """

    rate: float
    max_amount: float = 2.0
    joints: tuple[int, ...] = ()


@dataclass
class LightSpec:
    """A point lamp above the table (mm) and the ambient share of light (0-1)."""

    position: tuple[float, float, float] = (150.0, -250.0, 900.0)
    ambient: float = 0.55


@dataclass
class SceneSpec:
    """Everything the ``world:`` section sets, validated."""

    seed: int = 0
    table: TableSpec = field(default_factory=TableSpec)
    objects: list[ObjectSpec] = field(default_factory=list)
    duckybots: list[DuckybotSpec] = field(default_factory=list)
    faults: dict[str, dict[str, float]] = field(default_factory=dict)
    physics: PhysicsSpec = field(default_factory=PhysicsSpec)
    light: LightSpec = field(default_factory=LightSpec)
    tool_marker: MarkerSpec | None = None
    tool_marker_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    slips: SlipSpec | None = None
    #: ``world.randomize``: what ``--seed`` varies (None: nothing).
    randomize: Any = None
    #: ``world.as_built`` and ``world.reference``: how the rig really is, and the
    #: simulated measuring device's reading error (:mod:`.as_built`).
    as_built: AsBuilt = field(default_factory=AsBuilt)
    #: The sim camera's ``noise``, ``blur`` and ``drop_rate`` as a seed drew them.
    camera: dict[str, float] = field(default_factory=dict)
