"""The sim plugin wires the world into a rig and scores and records runs."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
from sim_fakes import C270, FakeEmulator

from armtree.api.clock import VirtualClock
from armtree.api.emulation import SHARED_KEY as EMULATOR_KEY
from armtree.api.rig import Rig, RigContext
from armtree.plugins.sim import plugin
from armtree.plugins.sim.camera import sim_camera
from armtree.plugins.sim.rig_world import WorldStepper
from armtree.plugins.sim.world import SHARED_KEY


@pytest.fixture
def build(camera_profile):
    """A factory: a rig of the sim camera and a stand-in arm, readied by the sim plugin."""

    def make(seed=0, record=None):
        profile = copy.deepcopy(camera_profile)
        profile["arm"] = {"type": "fake", "port": "sim"}
        profile["camera"] = dict(C270, type="sim")
        clock = VirtualClock()
        context = RigContext(profile=profile, clock=clock, seed=seed, record_dir=record)
        emulator = FakeEmulator()
        emulator.put([183, -6, 200])
        context.shared[EMULATOR_KEY] = emulator
        context.steppers.append(emulator.step)
        camera = sim_camera(profile["camera"], context)
        rig = Rig(profile=profile, clock=clock, camera=camera)
        plugin.armtree_rig_ready(rig=rig, context=context)
        rig.steppers.extend(context.steppers)
        return rig, context, emulator

    return make


def test_rig_ready_puts_the_arm_in_the_world_and_steps_it_after_the_emulator(build):
    rig, context, emulator = build()
    world = context.shared[SHARED_KEY]
    assert world.emulator is emulator
    assert rig.steppers[0] == emulator.step and isinstance(rig.steppers[1], WorldStepper)
    assert not any(world is v for v in vars(rig).values()), "the rig never holds the world"
    plugin.armtree_rig_ready(rig=rig, context=context)
    assert sum(isinstance(s, WorldStepper) for s in context.steppers) == 1, "idempotent"
    emulator.target = emulator.model.ik(np.array([150.0, 0.0, 100.0]))
    rig.step(0.5)
    assert world.time == 0.5
    assert np.allclose(world.arm.joints, emulator.q)


def test_rig_ready_ignores_profiles_without_sim_parts():
    context = RigContext(
        profile={"arm": {"type": "dobot_v1", "port": "/dev/ttyUSB0"}}, clock=VirtualClock()
    )
    plugin.armtree_rig_ready(rig=Rig(profile=context.profile, clock=context.clock), context=context)
    assert context.steppers == [] and SHARED_KEY not in context.shared


def fake_run(rig, directory, record):
    return SimpleNamespace(rig=rig, record_dir=directory, record_requested=record)


def test_run_finished_writes_the_score_beside_the_log(tmp_path, build):
    rig, context, emulator = build()
    run = fake_run(rig, tmp_path, False)
    plugin.armtree_run_started(run=run)
    rig.step(0.1)
    result = SimpleNamespace(
        status="SUCCESS", ticks=2, seconds=0.1, wall_seconds=0.01, log_path=tmp_path / "run.jsonl"
    )
    plugin.armtree_run_finished(run=run, result=result)
    score = json.loads((tmp_path / "score.json").read_text())
    assert score["run"]["status"] == "SUCCESS"
    assert score["objects"]["ducky"]["kind"] == "ducky"
    assert not (tmp_path / "camera.mp4").exists(), "videos only when recording was asked for"


def test_recording_writes_videos_png_and_score(tmp_path, build):
    rig, context, emulator = build(record=tmp_path)
    run = fake_run(rig, tmp_path, True)
    plugin.armtree_run_started(run=run)
    emulator.target = emulator.model.ik(np.array([150.0, 60.0, 180.0]))
    for _ in range(30):
        context.clock.advance(0.05)
        rig.step(context.clock.now())
        rig.camera.read()
    result = SimpleNamespace(
        status="FAILURE", ticks=30, seconds=1.5, wall_seconds=0.2, log_path=tmp_path / "run.jsonl"
    )
    plugin.armtree_run_finished(run=run, result=result)
    files = {p.name for p in Path(tmp_path).iterdir()}
    camera_video = next(n for n in files if n.startswith("camera."))
    overhead_video = next(n for n in files if n.startswith("overhead.") and not n.endswith(".png"))
    assert {"overhead.png", "score.json"} <= files
    frames = cv2.VideoCapture(str(tmp_path / camera_video))
    # 30 frames were read in 1.5 s; the video plays at the run's time: 1.5 s at 30 fps, from t = 0
    assert int(frames.get(cv2.CAP_PROP_FRAME_COUNT)) == 46
    assert frames.get(cv2.CAP_PROP_FPS) == pytest.approx(30.0, abs=1e-6)
    overhead = cv2.VideoCapture(str(tmp_path / overhead_video))
    assert int(overhead.get(cv2.CAP_PROP_FRAME_COUNT)) == 16  # 1.5 s at 10 frames/s, from t = 0
    png = cv2.imread(str(tmp_path / "overhead.png"))
    assert png.shape == (640, 640, 3)
    # The ducky (yellow) is drawn where the world has it.
    world = context.shared[SHARED_KEY]
    from armtree.plugins.sim.recording import Overhead

    u, v = Overhead(world).px(world.bodies["ducky"].pose[:2, 3])[0].astype(int)
    assert tuple(png[v - 8, u - 8]) == (40, 205, 250)


def test_a_body_inside_the_arm_at_start_is_a_config_error(camera_profile):
    import pytest

    from armtree.errors import ConfigError

    profile = camera_profile
    profile["world"]["objects"]["post"] = {
        "kind": "obstacle",
        "at": [183, -6],
        "size": [30, 30, 300],
    }
    context = RigContext(profile=profile, clock=VirtualClock())
    emulator = FakeEmulator()
    emulator.put([183, -6, 200])
    context.shared[EMULATOR_KEY] = emulator
    with pytest.raises(ConfigError, match="world.objects.post: post is inside the arm's"):
        plugin.armtree_rig_ready(rig=Rig(profile=profile, clock=context.clock), context=context)
