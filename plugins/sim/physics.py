"""Contact bookkeeping for the simulated world: arm links against bodies.

A collision is recorded once when a link box starts to interpenetrate a body
by more than a tolerance (touching to pick something up is not a collision)
and again only after the two have come apart. Millimetres, seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .geometry import obb_penetration


@dataclass(frozen=True)
class SolidBox:
    """An oriented box: ``name`` of its owner, centre ``pose`` (4x4), ``size`` (mm)."""

    name: str
    pose: np.ndarray
    size: np.ndarray

    @cached_property
    def radius(self) -> float:
        """Radius of the bounding sphere, mm."""
        return 0.5 * float(np.linalg.norm(self.size))

    @cached_property
    def centre(self) -> tuple[float, float, float]:
        """The box centre (x, y, z), mm."""
        x, y, z = self.pose[:3, 3].tolist()
        return x, y, z


def clearly_apart(a: SolidBox, b: SolidBox) -> bool:
    """True when the bounding spheres of ``a`` and ``b`` are apart by more than rounding.

    A cheap test in plain floats, with a margin far above what rounding can move
    a distance: where it says apart, the exact tests (:meth:`CollisionMonitor.update`'s
    sphere test, :func:`~.geometry.obb_penetration`) say so too, and it leaves every
    other pair to them.
    """
    (ax, ay, az), (bx, by, bz) = a.centre, b.centre
    reach = (a.radius + b.radius) * (1.0 + 1e-9) + 1e-9
    return (ax - bx) ** 2 + (ay - by) ** 2 + (az - bz) ** 2 > reach * reach


@dataclass(frozen=True)
class Collision:
    """A recorded contact: when (s), which link, which body, how deep (mm)."""

    time: float
    link: str
    other: str
    depth_mm: float


@dataclass
class CollisionMonitor:
    """Tracks which link-body pairs are in contact and logs each new contact."""

    tolerance: float = 3.0
    log: list[Collision] = field(default_factory=list)
    _active: set[tuple[str, str]] = field(default_factory=set)

    def update(
        self,
        now: float,
        links: list[SolidBox],
        bodies: list[SolidBox],
        extra: dict[tuple[str, str], float] | None = None,
    ) -> list[Collision]:
        """Test every link against every body; return the contacts that began now.

        ``extra`` adds contacts found by other tests, ``(link, other) -> depth`` (mm).
        """
        touching: dict[tuple[str, str], float] = {
            k: v for k, v in (extra or {}).items() if v > self.tolerance
        }
        for link in links:
            centre = link.pose[:3, 3]
            for body in bodies:
                # most pairs are far apart: the cheap test spares them NumPy's norm
                if clearly_apart(link, body):
                    continue
                gap = np.linalg.norm(body.pose[:3, 3] - centre) - link.radius - body.radius
                if gap > 0:
                    continue
                depth = obb_penetration(link.pose, link.size, body.pose, body.size)
                key = (link.name, body.name)
                if depth > self.tolerance and depth > touching.get(key, 0.0):
                    touching[key] = depth
        fresh = []
        for key, depth in sorted(touching.items()):
            if key not in self._active:
                fresh.append(Collision(round(now, 6), key[0], key[1], round(depth, 3)))
        self._active = set(touching)
        self.log.extend(fresh)
        return fresh
