"""What a monitor or a recording draws of a run's world: objects as boxes.

Skills never see these: they are the simulation's ground truth (or, on real
hardware, whatever a plugin knows of the scene), offered through the
``armtree_scene_objects`` hook for people to look at. Units: mm, base frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class SceneObject:
    """One object as a box.

    ``pose`` is the 4x4 pose of the box's centre in the arm's base frame (mm);
    ``size`` its (x, y, z) extents (mm); ``kind`` what it is (``"ducky"``,
    ``"bin"``, ``"table"``...); ``color`` RGB in 0..1; ``held`` whether the
    tool holds it; ``marker`` the id of the marker on its top, if any.
    """

    name: str
    kind: str
    pose: np.ndarray
    size: tuple[float, float, float]
    color: tuple[float, float, float] = (0.6, 0.6, 0.6)
    held: bool = False
    marker: int | None = None
    #: Extra outline in the table plane (x, y mm), e.g. a robot's planned route.
    route: list[tuple[float, float]] = field(default_factory=list)


__all__ = ["SceneObject"]
