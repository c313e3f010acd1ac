"""Fixtures shared across test files.

The sim tests put markers into worlds: ``sim_profile`` gives a profile with the
shared tracker and tag roles and any ``world:``; ``make_world`` builds the
world of the physics tests (scoring, grasping, release) with an arm in it;
``camera_profile`` is the scene the camera and plugin tests look at.
"""

from __future__ import annotations

import copy
from collections.abc import Callable

import pytest
from hypothesis import settings
from sim_fakes import FakeEmulator

from armtree.plugins.sim.scene import parse_scene
from armtree.plugins.sim.world import World

# A property's deadline measures how busy the machine is, not whether the property holds:
# on two shared cores one example can take longer than hypothesis's default 200 ms.
settings.register_profile("armtree", deadline=None)
settings.load_profile("armtree")

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


#: The physics tests' table: a ducky, trash, a bin, a wall and a Duckybot that parks.
WORLD_SCENE = {
    "table": {"x": [-300, 400], "y": [-400, 400]},
    "objects": {
        "ducky": {"kind": "ducky", "at": [200, -100]},
        "trash": {"kind": "trash", "at": [150, 150]},
        "bin": {"kind": "bin", "at": [0, 250], "size": [90, 90, 35]},
        "wall": {"kind": "obstacle", "at": [250, 100], "size": [40, 40, 150]},
    },
    "duckybots": {
        "bot": {
            "start": [220, -300, 90],
            "size": [90, 70, 40],
            "route": [
                {"park": [220, 0, 90], "until": "loaded", "wait_s": 1.0},
                {"drive_to": [220, 200]},
            ],
        }
    },
}

#: What the camera tests look at: a ducky and trash near the arm, turned a little.
CAMERA_SCENE = {
    "table": {"x": [-300, 500], "y": [-400, 400]},
    "objects": {
        "ducky": {"kind": "ducky", "at": [230, -30], "yaw": 20},
        "trash": {"kind": "trash", "at": [180, 40], "yaw": -15},
    },
}


@pytest.fixture
def make_world(sim_profile) -> Callable[..., tuple[World, FakeEmulator]]:
    """A factory: the physics tests' world (seed 3) with these sections replaced, and its arm."""

    def make(**world_changes) -> tuple[World, FakeEmulator]:
        profile = sim_profile(WORLD_SCENE)
        profile["world"].update(world_changes)
        world = World(parse_scene(profile), seed=3)
        emulator = FakeEmulator()
        emulator.put([200, 0, 200])
        world.attach_arm(emulator)
        world.step(0.0)
        return world, emulator

    return make


@pytest.fixture
def camera_profile(sim_profile) -> dict:
    """A fresh profile of the camera tests' scene."""
    return sim_profile(CAMERA_SCENE)


@pytest.fixture(scope="session")
def recorded_run(tmp_path_factory):
    """A simulated pick and place recorded with ``--record`` (run.jsonl, run.mcap), made once."""
    from monitor_helpers import record_run

    return record_run(tmp_path_factory.mktemp("recorded"))
