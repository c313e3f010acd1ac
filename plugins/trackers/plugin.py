"""Registration of the built-in trackers plugin.

Trackers ``aruco``, ``apriltag`` and ``hamming``; the profile's ``tags:`` checked
against the tracker's marker family; commands ``armtree detect``,
``armtree markers`` (``armtree calibrate`` lives in the calibration plugin).
"""

from __future__ import annotations

from typing import Any

import armtree
from armtree.loader.profile import Profile

from .aruco import apriltag_factory, aruco_factory
from .commands import DetectCommand, MarkersCommand
from .hamming import hamming_factory
from .tag_checks import tag_problems


@armtree.hookimpl
def armtree_trackers() -> dict[str, Any]:
    """The ``aruco``, ``apriltag`` and ``hamming`` marker trackers."""
    return {"aruco": aruco_factory, "apriltag": apriltag_factory, "hamming": hamming_factory}


@armtree.hookimpl
def armtree_validate_profile(profile: Profile) -> list[Any]:
    """``tags:`` ids against their marker families (docs/trackers.md)."""
    return tag_problems(profile)


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """``detect`` and ``markers``."""
    return {"detect": DetectCommand(), "markers": MarkersCommand()}
