"""Fixtures shared across test files.

``sim_profile``: the sim tests (scene, world, camera) put markers into worlds of
their own; the tracker and the tag roles those markers play are the same in each.
"""

from __future__ import annotations

import copy
from collections.abc import Callable

import pytest

#: The tracker and tag roles of the sim tests' worlds (ArUco 4x4_50, 25 mm markers).
SIM_MARKERS = {
    "tracker": {"type": "aruco", "dictionary": "4x4_50"},
    "tags": {
        "ducky": {"id": 0, "size_mm": 25},
        "duckybot": {"id": 1, "size_mm": 25},
        "trash": {"ids": [2, 3, 4], "size_mm": 25},
    },
}


@pytest.fixture
def sim_profile() -> Callable[[dict], dict]:
    """A factory: a fresh profile with the shared tracker and tags and the given ``world:``."""

    def make(world: dict) -> dict:
        return copy.deepcopy({**SIM_MARKERS, "world": world})

    return make
