"""The episode recorder on a rig of plain fakes (no simulation): what the driver read,
what the arm was told, the frames the run read and nothing else."""

from __future__ import annotations

import av
import numpy as np
import pytest

from armtree.api.rig import Frame, MotionHandle, MotionStatus, ToolState
from armtree.maths.motion.kinematics import Joint
from armtree.plugins.dataset.recorder import EpisodeRecorder
from armtree.plugins.dataset.video import frame_times

TICK = 0.05


class Model:
    name = "fake"
    joints = (Joint("j1", "revolute", -90, 90), Joint("z", "prismatic", 0, 100))
    dof = 2
    home = np.array([0.0, 50.0])


class Arm:
    """Reports the joints it is given; a target outside +-90 degrees is refused."""

    def __init__(self) -> None:
        self.model = Model()
        self.q = np.array([1.0, 10.0])
        self.reported_tool = ToolState(suction=False, gripper=None)

    def joints(self) -> np.ndarray:
        return self.q.copy()

    @property
    def tool(self) -> ToolState:
        return self.reported_tool

    def move_joints(self, q, speed: float = 1.0) -> MotionHandle:
        handle = MotionHandle("move", np.asarray(q, dtype=float))
        if abs(q[0]) > 90:
            handle.update(MotionStatus.FAILED, error=ValueError("out of range"))
        else:
            handle.update(MotionStatus.RUNNING)
        return handle

    def set_suction(self, on: bool) -> MotionHandle:
        handle = MotionHandle("suction")
        handle.update(MotionStatus.DONE)
        return handle

    def stop(self) -> None:
        pass


class Camera:
    """Hands out the frame it was given, once."""

    def __init__(self) -> None:
        self.pending = None
        self.reads = 0

    def read(self):
        self.reads += 1
        frame, self.pending = self.pending, None
        return frame


class Rig:
    def __init__(self) -> None:
        self.arm, self.camera = Arm(), Camera()


def frame(value: int, t: float) -> Frame:
    return Frame(np.full((32, 48, 3), value, np.uint8), t, np.eye(3), np.zeros(5))


def test_state_action_and_images_come_from_the_rigs_public_parts(tmp_path):
    rig = Rig()
    recorder = EpisodeRecorder(rig, 10, tmp_path / "episode")
    arm, camera = rig.arm, rig.camera
    for tick in range(8):  # 0 to 0.35 s; what the tree does at ticks 2, 4 and 6
        arm.q = np.array([1.0 + tick, 10.0])
        if tick == 2:
            camera.pending = frame(40, 0.1)
            camera.read()
            arm.move_joints([30.0, 20.0])
        elif tick == 4:
            arm.move_joints([120.0, 0.0])
            arm.set_suction(True)
        elif tick == 6:
            arm.stop()
            camera.pending = frame(200, 0.3)
            camera.read()
        recorder.tick(tick * TICK)
    assert camera.reads == 2, "the recorder reads no frame of its own"
    episode = recorder.finish("touch", "fake", {"seed": 3})
    assert episode.length == 4 and episode.joints == ["j1", "z"]
    state = episode.state
    assert state[:, 0].tolist() == [1.0, 3.0, 5.0, 7.0]  # the joints at 0, 0.1, 0.2, 0.3 s
    assert state[:, 2].tolist() == [0.0, 0.0, 0.0, 0.0]  # the arm reports no suction
    action = episode.action
    assert action[0, :2].tolist() == [1.0, 10.0]  # nothing told yet: where it is
    assert action[1, :2].tolist() == [30.0, 20.0]
    assert action[2, :2].tolist() == [30.0, 20.0]  # the refused move changed nothing
    assert action[2, 2] == 1.0  # suction on, as told
    assert action[3, :2].tolist() == [7.0, 10.0]  # stopped: where it is
    assert episode.image_shape == (32, 48, 3)
    times = frame_times(episode.video)
    assert times == pytest.approx([0.0, 0.1, 0.2, 0.3], abs=1e-6)
    with av.open(str(episode.video)) as video:
        greys = [int(f.to_ndarray(format="rgb24")[16, 24, 0]) for f in video.decode(video=0)]
    # the first frame read stands for the frame before it, and stays until the next
    assert [round(g / 10) for g in greys] == [4, 4, 4, 20]
    assert "read" not in vars(camera) and "move_joints" not in vars(arm), "taps removed"


def test_a_camera_that_gave_no_frame_leaves_no_episode(tmp_path):
    rig = Rig()
    recorder = EpisodeRecorder(rig, 10, tmp_path / "episode")
    for tick in range(4):
        recorder.tick(tick * TICK)
    with pytest.raises(ValueError, match="the camera gave the run no frame"):
        recorder.finish("touch", "fake", {})
    recorder.discard()
    assert not list(tmp_path.iterdir())


def test_a_rig_without_a_camera_records_state_and_action_only(tmp_path):
    rig = Rig()
    rig.camera = None
    recorder = EpisodeRecorder(rig, 5, tmp_path / "episode")
    for tick in range(9):
        recorder.tick(tick * TICK)
    episode = recorder.finish("touch", "fake", {})
    assert episode.length == 3 and episode.video is None and episode.image_shape is None
    assert "observation.images.camera" not in episode.features()
