"""Registration of the built-in trackers plugin: the ``aruco`` and ``hamming`` trackers."""

from __future__ import annotations

from typing import Any

import armtree

from .aruco import aruco_factory
from .hamming import hamming_factory


@armtree.hookimpl
def armtree_trackers() -> dict[str, Any]:
    """The ``aruco`` and ``hamming`` marker trackers."""
    return {"aruco": aruco_factory, "hamming": hamming_factory}
