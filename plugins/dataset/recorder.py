"""One run recorded as an episode, at the dataset's fps, through the rig's public parts.

Each dataset frame ``k`` is taken at the first tick at or after ``k / fps`` seconds
of run time:

* ``observation.state``: the joints as the arm's driver last read them
  (``arm.joints()``, degrees / mm), then the tool as the arm reports it
  (``arm.tool``: suction 0 or 1, gripper opening; 0 when it reports none);
* ``action``: what the arm was last told, in the same layout: the joint target of
  the newest motion command (``move_joints``, ``move_to``, ``follow_path``'s last
  waypoint, ``home``; a command the driver refused sends nothing and changes
  nothing), the suction and gripper last set; where nothing is commanded (before
  the first command, after ``stop``) the measured value;
* ``observation.images.camera``: the newest frame the run read from the camera
  (``camera.read``, whatever the camera). A frame stands until the run reads the
  next one, and the first one also for the frames before it: the video shows what
  the tree saw, and recording reads no frame of its own, so a run behaves the same
  with and without ``--dataset``.

Nothing here knows the simulation: the same recorder runs on the bench.
"""

from __future__ import annotations

import contextlib
import functools
import shutil
from collections import Counter
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from armtree.api.rig import MotionStatus, Rig, frame_index

from . import stats
from .episode import PARTIAL, VIDEO_FILE, Episode
from .video import EpisodeVideo

#: Arm methods whose call says what the arm is now told to do.
_COMMANDS = ("move_joints", "move_to", "follow_path", "home", "set_suction", "set_gripper", "stop")


class CommandTaps:
    """What the arm was last told: joint target, suction, gripper (None: nothing told).

    Wraps the arm instance's command methods; :meth:`remove` puts them back.
    """

    def __init__(self, arm: Any) -> None:
        self.arm = arm
        self.dof = int(arm.model.dof)
        self.joints: np.ndarray | None = None
        self.suction: bool | None = None
        self.gripper: float | None = None
        self._wrapped: list[str] = []
        for name in _COMMANDS:
            if callable(getattr(arm, name, None)):
                self._wrap(name)

    def _wrap(self, name: str) -> None:
        original = getattr(self.arm, name)
        note = getattr(self, f"_on_{name}")

        @functools.wraps(original)
        def tapped(*args: Any, **kwargs: Any) -> Any:
            result = original(*args, **kwargs)
            # Recording must never break a command.
            with contextlib.suppress(Exception):
                note(result, *args, **kwargs)
            return result

        setattr(self.arm, name, tapped)
        self._wrapped.append(name)

    def _target(self, handle: Any, fallback: Any = None) -> None:
        if getattr(handle, "status", None) is MotionStatus.FAILED and handle.done:
            return  # refused before a byte was sent
        for candidate in (getattr(handle, "target", None), fallback):
            if candidate is None:
                continue
            q = np.asarray(candidate, dtype=float).reshape(-1)
            if q.shape == (self.dof,) and np.all(np.isfinite(q)):
                self.joints = q.copy()
                return
        self.joints = None  # told to go somewhere this recorder cannot name in joints

    def _on_move_joints(self, handle: Any, q: Any, *_: Any, **__: Any) -> None:
        self._target(handle, q)

    def _on_move_to(self, handle: Any, *_: Any, **__: Any) -> None:
        self._target(handle)

    def _on_follow_path(self, handle: Any, waypoints: Any, *_: Any, **__: Any) -> None:
        self._target(handle, np.atleast_2d(np.asarray(waypoints, dtype=float))[-1])

    def _on_home(self, handle: Any, *_: Any, **__: Any) -> None:
        self._target(handle, self.arm.model.home)

    def _on_set_suction(self, handle: Any, on: Any, *_: Any, **__: Any) -> None:
        if not (getattr(handle, "status", None) is MotionStatus.FAILED and handle.done):
            self.suction = bool(on)

    def _on_set_gripper(self, handle: Any, opening: Any, *_: Any, **__: Any) -> None:
        if not (getattr(handle, "status", None) is MotionStatus.FAILED and handle.done):
            self.gripper = float(opening)

    def _on_stop(self, *_: Any, **__: Any) -> None:
        self.joints = None  # it stops where it is

    def remove(self) -> None:
        """Put the arm's own methods back (idempotent)."""
        while self._wrapped:
            name = self._wrapped.pop()
            if name in vars(self.arm):
                delattr(self.arm, name)


class FrameTap:
    """The newest frame the run read from a camera (wraps ``camera.read``)."""

    def __init__(self, camera: Any) -> None:
        self.camera = camera
        self.newest: Any = None
        original = camera.read

        @functools.wraps(original)
        def read(*args: Any, **kwargs: Any) -> Any:
            frame = original(*args, **kwargs)
            if frame is not None:
                self.newest = frame
            return frame

        camera.read = read

    def remove(self) -> None:
        """Put the camera's own ``read`` back (idempotent)."""
        if "read" in vars(self.camera):
            delattr(self.camera, "read")


class EpisodeRecorder:
    """Samples a run's rig at ``fps`` into an :class:`Episode` whose files go to ``folder``.

    ``folder`` is where the episode will be staged; the recording is made in
    ``folder.partial`` meanwhile. ``threads`` is the video encoder's.
    """

    def __init__(self, rig: Rig | None, fps: int, folder: Path, threads: int = 1) -> None:
        arm = getattr(rig, "arm", None)
        if arm is None:
            raise ValueError("the rig has no arm: an episode records an arm's joints")
        self.arm = arm
        self.fps = int(fps)
        self.folder = Path(folder)
        self.work = self.folder.with_name(self.folder.name + PARTIAL)
        if self.work.exists():
            shutil.rmtree(self.work)
        self.work.mkdir(parents=True)
        self.threads = threads
        self.joint_names = [j.name for j in arm.model.joints]
        self.commands = CommandTaps(arm)
        camera = getattr(rig, "camera", None)
        self.frames = FrameTap(camera) if camera is not None else None
        self.state: list[np.ndarray] = []
        self.action: list[np.ndarray] = []
        self.video: EpisodeVideo | None = None
        self._waiting = 0  # frames taken before the camera gave the run its first image
        self._shown: Any = None  # the frame the video shows now
        self._image: np.ndarray | None = None
        self._samples: list[np.ndarray] = []  # each new image, small, RGB, for statistics
        self._shown_at: list[int] = []  # for each dataset frame, its image among _samples
        self._closed = False

    @property
    def length(self) -> int:
        """Frames recorded so far."""
        return len(self.state)

    def tick(self, now: float) -> None:
        """Take every dataset frame due by run time ``now`` (s); call after each tick."""
        due = frame_index(now, self.fps)
        while self.length <= due:
            self._take()

    def _take(self) -> None:
        arm, told = self.arm, self.commands
        q = np.asarray(arm.joints(), dtype=np.float64).reshape(-1)
        tool = arm.tool
        suction = 1.0 if tool.suction else 0.0
        gripper = float(tool.gripper) if tool.gripper is not None else 0.0
        self.state.append(np.concatenate([q, [suction, gripper]]).astype(np.float32))
        action_q = told.joints if told.joints is not None else q
        action_suction = suction if told.suction is None else float(told.suction)
        action_gripper = gripper if told.gripper is None else told.gripper
        self.action.append(
            np.concatenate([action_q, [action_suction, action_gripper]]).astype(np.float32)
        )
        if self.frames is not None:
            self._take_image(self.frames.newest)

    def _take_image(self, frame: Any) -> None:
        if frame is None:
            self._waiting += 1
            return
        if frame is not self._shown:
            self._shown = frame
            image = frame.image
            if image.ndim == 2:
                image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
            self._image = image
            self._samples.append(np.ascontiguousarray(stats.downsample(image)[..., ::-1]))
        assert self._image is not None
        if self.video is None:
            height, width = self._image.shape[:2]
            self.video = EpisodeVideo(self.work / VIDEO_FILE, self.fps, width, height, self.threads)
        repeat = 1 + self._waiting
        self._shown_at.extend([len(self._samples) - 1] * repeat)
        self._waiting = 0
        self.video.add(self._image, repeat)

    def finish(self, task: str, robot_type: str | None, tags: dict[str, Any]) -> Episode:
        """The episode as recorded, its video closed; ValueError when there is none to keep
        (no frame, or a camera that gave the run no image)."""
        self.remove_taps()
        if self.length == 0:
            raise ValueError("the run ended before its first frame")
        image_shape = None
        image_stats = None
        video_path = None
        if self.frames is not None:
            if self.video is None:
                raise ValueError("the camera gave the run no frame, so the episode has no images")
            self.video.finish()
            assert self._image is not None  # set with the video
            image_shape = (*self._image.shape[:2], 3)
            picks = Counter(self._shown_at[i] for i in stats.sample_indices(len(self._shown_at)))
            image_stats = stats.of_images([self._samples[i] for i in picks], list(picks.values()))
            video_path = self.work / VIDEO_FILE
        self._closed = True
        return Episode(
            fps=self.fps,
            task=task,
            robot_type=robot_type,
            joints=self.joint_names,
            state=np.stack(self.state),
            action=np.stack(self.action),
            video=video_path,
            image_shape=image_shape,
            image_stats=image_stats,
            tags=dict(tags),
        )

    def remove_taps(self) -> None:
        """Give the arm and camera their own methods back (idempotent)."""
        self.commands.remove()
        if self.frames is not None:
            self.frames.remove()

    def discard(self) -> None:
        """Drop the recording: taps removed, video closed, files deleted (safe twice)."""
        self.remove_taps()
        if self.video is not None:
            with contextlib.suppress(Exception):
                self.video.close()
        shutil.rmtree(self.work, ignore_errors=True)


__all__ = ["CommandTaps", "EpisodeRecorder", "FrameTap"]
