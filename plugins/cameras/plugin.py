"""Registration of the built-in cameras plugin: ``opencv``, ``video`` and ``images``.

The ``sim`` camera is registered by the simulation plugin.
"""

from __future__ import annotations

from typing import Any

import armtree

from .opencv_camera import opencv_factory
from .replay import images_factory, video_factory


@armtree.hookimpl
def armtree_cameras() -> dict[str, Any]:
    """A USB camera through OpenCV, and video / image-folder replay."""
    return {"opencv": opencv_factory, "video": video_factory, "images": images_factory}
