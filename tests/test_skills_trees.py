"""The shipped trees, loaded by armtree.load_tree and run by armtree.run on a rig of fakes.

The fakes of test_skills_fakes are registered as an armtree plugin (arm, camera,
tracker and planner types) so the trees go through the real loader, the real
rig builder and the real runtime; only the hardware is fake.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from test_skills_fakes import (
    PLACES,
    TICK,
    FakeArm,
    FakeCamera,
    FakePlanner,
    FakeTracker,
    Marker,
    World,
    _clean_blackboard,  # noqa: F401
)

import armtree
from armtree.api.clock import VirtualClock
from armtree.config.resolve import available
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.tree_loader import load_tree
from armtree.runtime.rig_builder import build_rig
from armtree.runtime.runner import run


def _arm(config: dict, context: Any) -> FakeArm:
    """A fake cylindrical arm stepping with the run."""
    world = context.shared.setdefault("world", World([]))
    arm = FakeArm(world, ticks=int(config.get("ticks", 2)))
    context.shared["arm"] = arm

    def step(now: float) -> None:
        arm.step()
        world.step(now, TICK, arm.actual_pose()[:3, 3])

    context.steppers.append(step)
    return arm


def _camera(config: dict, context: Any) -> FakeCamera:
    """A fake eye-in-hand camera; ``markers`` lists [id, x, y, z, vx, vy, stop_at] of the world."""
    world = context.shared["world"]
    for spec in config.get("markers", []):
        mid, x, y, z, *rest = spec
        vx, vy, stop = (rest + [0.0, 0.0, 0.0])[:3]
        world.markers[int(mid)] = Marker(
            int(mid), np.array([x, y, z], float), np.array([vx, vy, 0.0]), stop
        )
    cam = FakeCamera(context.clock, context.shared["arm"])
    context.shared["camera"] = cam
    return cam


def _tracker(config: dict, context: Any) -> FakeTracker:
    """A fake tracker reporting the world's markers in view."""
    return FakeTracker(context.shared["world"], context.shared["camera"])


def _planner(config: dict, context: Any, model: Any, scene: Any) -> FakePlanner:
    """A fake straight-line planner."""
    return FakePlanner(model)


class FakeHardware:
    """armtree plugin registering the fakes."""

    @armtree.hookimpl
    def armtree_arms(self) -> dict[str, Any]:
        return {"fake_cyl": _arm}

    @armtree.hookimpl
    def armtree_cameras(self) -> dict[str, Any]:
        return {"fake_cam": _camera}

    @armtree.hookimpl
    def armtree_trackers(self) -> dict[str, Any]:
        return {"fake_tracker": _tracker}

    @armtree.hookimpl
    def armtree_planners(self) -> dict[str, Any]:
        return {"fake_planner": _planner}


def arc(deg: float, r: float = 185.0) -> list[float]:
    """A point of the fake profile's survey ring (r = 185 mm, a little below its table at z = -35 mm)."""
    return [r * math.cos(math.radians(deg)), r * math.sin(math.radians(deg)), -40.0]


@pytest.fixture
def manager() -> PluginManager:
    # only the framework and the skills: the hardware plugins are replaced by the fakes
    hardware = ("arms", "dobot_v1", "dobot_magician", "vicra", "dh", "cameras", "trackers")
    m = PluginManager(blocked=(*hardware, "planners", "sim"), autoload=True)
    m.load_entry_points()
    m.register(FakeHardware(), "skills_fakes")
    return m


def write_profile(tmp_path: Path, markers: list[list[float]]) -> Path:
    profile = {
        "profile": "fake",
        "arm": {"type": "fake_cyl", "port": "sim"},
        "camera": {"type": "fake_cam", "markers": markers},
        "tracker": {"type": "fake_tracker"},
        "planner": {"type": "fake_planner"},
        "tags": {
            "ducky": {"id": 0, "size_mm": 25},
            "duckybot": {"id": 1, "size_mm": 25},
            "trash": {"ids": [2, 3, 4], "size_mm": 25},
        },
        "places": PLACES,
        # the ring of the sim_dobot profile, on a table a little above the markers
        "workcell": {
            "table_z_mm": -35,
            "clearance_z_mm": 20,
            "look_height_mm": 100,
            "survey": {"ring": {"radius_mm": 185, "range_deg": [-100, 100], "step_deg": 5}},
            "release_offset_mm": 35,
        },
    }
    path = tmp_path / "fake.yaml"
    path.write_text(yaml.safe_dump(profile))
    return path


def run_tree(name: str, profile: Path, manager: PluginManager, overrides=()) -> tuple[Any, Any]:
    tree = load_tree(name, rig=profile, overrides=overrides, manager=manager)
    rig = build_rig(tree.profile, manager, VirtualClock())
    result = run(tree, rig=rig, record=False, manager=manager, max_ticks=20000)
    rig.tree = tree
    return result, rig


def feedback(tree: Any, name: str) -> str:
    """The feedback message of the node called ``name``."""
    return next(b.feedback_message for b in tree.root.iterate() if b.name == name)


def test_load_ducky_runs_end_to_end_on_fakes(tmp_path, manager):
    bot_start = arc(55.0)
    markers = [
        [0, *PLACES["ducky_pickup"]],
        [1, bot_start[0], bot_start[1], -40.0, -10.0, 0.0, 2.0],  # drives 20 mm, then parks
        [3, *arc(20.0)],  # trash on the search arc
    ]
    result, rig = run_tree("load_ducky.yaml", write_profile(tmp_path, markers), manager)
    assert result.status == "SUCCESS", result.message
    world = rig.arm.world
    ducky, bot, trash = world.markers[0], world.markers[1], world.markers[3]
    assert ducky.dropped_at is not None
    assert np.linalg.norm(ducky.dropped_at[:2] - bot.position[:2]) < 3.0
    assert trash.dropped_at is not None and np.allclose(
        trash.dropped_at[:2], PLACES["garbage_bin"][:2]
    )
    assert np.allclose(rig.arm.q, rig.arm.model.home)


def test_load_ducky_without_clean_up_leaves_the_trash(tmp_path, manager):
    markers = [[0, *PLACES["ducky_pickup"]], [1, *arc(55.0)], [3, *arc(20.0)]]
    result, rig = run_tree(
        "load_ducky.yaml", write_profile(tmp_path, markers), manager, ["clean_up=false"]
    )
    assert result.status == "SUCCESS", result.message
    assert rig.arm.world.markers[3].dropped_at is None
    assert rig.arm.world.markers[0].dropped_at is not None


def test_load_ducky_fails_clearly_without_a_duckybot(tmp_path, manager):
    result, rig = run_tree(
        "load_ducky.yaml", write_profile(tmp_path, [[0, *PLACES["ducky_pickup"]]]), manager
    )
    assert result.status == "FAILURE"
    assert result.failed_node.endswith(
        "Search for the duckybot/Trash first, then look on/Sweep for the duckybot"
    )
    assert "no 'duckybot' tag seen from" in feedback(rig.tree, "Sweep for the duckybot")
    assert not rig.arm.suction


def test_clean_up_tree_sweeps_and_bins_all_trash(tmp_path, manager):
    markers = [[2, *arc(-30.0)], [4, *arc(45.0)]]
    result, rig = run_tree("clean_up.yaml", write_profile(tmp_path, markers), manager, ["sweeps=2"])
    assert result.status == "SUCCESS", result.message
    for mid in (2, 4):
        assert np.allclose(rig.arm.world.markers[mid].dropped_at[:2], PLACES["garbage_bin"][:2])


def test_pick_and_place_tree_moves_the_ducky(tmp_path, manager):
    result, rig = run_tree(
        "pick_and_place.yaml", write_profile(tmp_path, [[0, *PLACES["ducky_pickup"]]]), manager
    )
    assert result.status == "SUCCESS", result.message
    assert np.allclose(rig.arm.world.markers[0].dropped_at, PLACES["garbage_bin"])


def test_track_tree_follows_the_duckybot_until_it_parks(tmp_path, manager):
    start = arc(30.0)
    markers = [[1, start[0], start[1], -40.0, 0.0, 15.0, 2.0]]
    result, rig = run_tree("track.yaml", write_profile(tmp_path, markers), manager)
    assert result.status == "SUCCESS", result.message
    bot = rig.arm.world.markers[1].position
    cam = (rig.arm.actual_pose() @ rig.camera.extrinsics)[:2, 3]
    assert np.linalg.norm(cam - bot[:2]) < 15.0


def test_touch_tag_tree_servos_over_the_tag_within_3_mm(tmp_path, manager):
    markers = [[1, *arc(25.0)]]
    result, rig = run_tree("touch_tag.yaml", write_profile(tmp_path, markers), manager)
    assert result.status == "SUCCESS", result.message
    tool = rig.arm.actual_pose()[:3, 3]
    assert np.linalg.norm(tool - (np.array(arc(25.0)) + [0, 0, 20])) < 3.0


@pytest.mark.parametrize(
    "rig", ["sim_dobot", "sim_vicra", "sim_magician", "sim_dh", "sim_so101", "sim_koch"]
)
@pytest.mark.parametrize("name", available("tree"))
def test_every_shipped_tree_loads_unchanged_on_every_sim_rig(name, rig):
    tree = load_tree(name, rig=rig, overrides=["tag=duckybot"] if name == "search" else [])
    assert tree.profile.name == rig
