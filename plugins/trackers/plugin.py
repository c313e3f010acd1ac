"""Registration of the built-in trackers plugin.

Trackers ``aruco`` and ``hamming``; commands ``armtree detect``,
``armtree markers`` and ``armtree calibrate``.
"""

from __future__ import annotations

from typing import Any

import armtree

from .aruco import aruco_factory
from .calibrate_command import CalibrateCommand
from .commands import DetectCommand, MarkersCommand
from .hamming import hamming_factory


@armtree.hookimpl
def armtree_trackers() -> dict[str, Any]:
    """The ``aruco`` and ``hamming`` marker trackers."""
    return {"aruco": aruco_factory, "hamming": hamming_factory}


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """``detect``, ``markers`` and ``calibrate``."""
    return {"detect": DetectCommand(), "markers": MarkersCommand(), "calibrate": CalibrateCommand()}
