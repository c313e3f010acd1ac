"""Registration of the built-in trackers plugin.

Trackers ``aruco`` and ``hamming``; commands ``armtree detect``,
``armtree markers`` (``armtree calibrate`` lives in the calibration plugin).
"""

from __future__ import annotations

from typing import Any

import armtree

from .aruco import aruco_factory
from .commands import DetectCommand, MarkersCommand
from .hamming import hamming_factory


@armtree.hookimpl
def armtree_trackers() -> dict[str, Any]:
    """The ``aruco`` and ``hamming`` marker trackers."""
    return {"aruco": aruco_factory, "hamming": hamming_factory}


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """``detect`` and ``markers``."""
    return {"detect": DetectCommand(), "markers": MarkersCommand()}
