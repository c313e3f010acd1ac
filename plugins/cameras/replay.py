"""The ``video`` and ``images`` cameras: replay a recording for offline runs and tests.

Pacing follows the run's clock (``pace: clock``): frame ``i`` is shown from
``i / fps`` seconds after ``start()``, so a run on the virtual clock sees the
same frames at the same ticks every time. ``pace: each`` hands out the next
frame on every ``read()`` (batch work such as measuring a detection rate).
Frames are decoded in ``read()`` itself rather than on a thread: decoding one
frame takes a few milliseconds, and doing it in step keeps replays
deterministic. At the end of the recording ``read()`` returns None (or starts
again with ``loop: true``) and ``finished`` becomes True.
"""

from __future__ import annotations

import glob
from abc import abstractmethod
from collections.abc import Iterator
from pathlib import Path
from typing import Any, cast

import cv2
import numpy as np

from armtree.api.component_factory import ComponentFactory
from armtree.api.imaging import INTRINSICS_PARAMS, video_fps
from armtree.api.rig import Frame, RigContext
from armtree.config.component_config import config_error
from armtree.config.params import Param
from armtree.errors import ConfigError, HardwareFault

from .base import FrameSourceCamera, camera_config

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm", ".webp")


class ReplayCamera(FrameSourceCamera):
    """Base of the replay cameras: pacing by clock or by call, looping, end of recording."""

    #: Set from a checked positive rate in __init__, never None as a Camera's may be.
    fps: float

    def __init__(
        self, name: str, clock: Any, intrinsics: Any, fps: float, pace: str, loop: bool, **kw: Any
    ) -> None:
        super().__init__(name, clock, intrinsics, **kw)
        self.fps = float(fps)
        self.pace = pace
        self.loop = loop
        self.finished = False
        self._t0 = 0.0
        self._shown = -1  # index (in the recording's timeline) of the last frame handed out
        self._started = False

    def start(self) -> None:
        """Open the recording and start its timeline at the clock's current time."""
        self._open()
        self._t0 = self.clock.now()
        self._shown = -1
        self.finished = False
        self._started = True

    def read(self) -> Frame | None:
        """The frame due now (or the next one with ``pace: each``), None if none is new."""
        if not self._started or self.finished:
            return None
        if self.pace == "each":
            due = self._shown + 1
        else:
            due = int(np.floor((self.clock.now() - self._t0) * self.fps + 1e-9))
        if due <= self._shown:
            return None
        image = self._image_at(due)
        if image is None and self.loop and due > 0:
            self._rewind()
            self._t0, self._shown, due = self.clock.now(), -1, 0
            image = self._image_at(0)
        if image is None:
            self.finished = True
            return None
        self._shown = due
        return self.make_frame(image, self._t0 + due / self.fps)

    def frames(self) -> Iterator[Frame]:
        """Every frame of the recording once, in order, whatever the pacing."""
        pace, loop = self.pace, self.loop
        self.pace, self.loop = "each", False
        try:
            self.start()
            while (frame := self.read()) is not None:
                yield frame
        finally:
            self.pace, self.loop = pace, loop

    @abstractmethod
    def _open(self) -> None:
        """Open the recording; ConfigError naming it if it cannot be."""

    @abstractmethod
    def _image_at(self, index: int) -> np.ndarray | None:
        """Image ``index`` of the recording, None past its end."""

    def _rewind(self) -> None:
        """Go back to the start (a video reopens; images need nothing)."""


class ImagesCamera(ReplayCamera):
    """A folder (or glob) of images replayed in name order."""

    def __init__(self, paths: list[Path], clock: Any, intrinsics: Any, **kw: Any) -> None:
        super().__init__(f"images {paths[0].parent}", clock, intrinsics, **kw)
        self.paths = paths

    def _open(self) -> None:
        pass

    def _image_at(self, index: int) -> np.ndarray | None:
        if index >= len(self.paths):
            return None
        path = self.paths[index]
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if image is None:
            raise HardwareFault(
                "cannot decode image (unreadable, empty or not an image)", str(path)
            )
        return image


class VideoCamera(ReplayCamera):
    """A video file replayed frame by frame (any format OpenCV's backends decode)."""

    def __init__(self, path: Path, clock: Any, intrinsics: Any, **kw: Any) -> None:
        super().__init__(f"video {path}", clock, intrinsics, **kw)
        self.path = path
        self._capture: Any = None
        self._position = 0  # index of the next frame the capture will decode

    def _open(self) -> None:
        self.close()
        cap = cv2.VideoCapture(str(self.path))
        if not cap.isOpened():
            raise ConfigError("cannot open video (unreadable or not a video)", file=str(self.path))
        self._capture = cap
        self._position = 0

    def _image_at(self, index: int) -> np.ndarray | None:
        cap = self._capture
        if index < self._position:
            self._open()
            cap = self._capture
        while self._position < index:
            if not cap.grab():
                return None
            self._position += 1
        ok, image = cap.read()
        if not ok:
            return None
        self._position += 1
        return image

    def _rewind(self) -> None:
        self._open()

    def close(self) -> None:
        """Release the file."""
        if self._capture is not None:
            self._capture.release()
            self._capture = None


def image_paths(spec: str, where: Any = None) -> list[Path]:
    """The images of a folder or a glob pattern, sorted by name; ConfigError when there are none."""
    path = Path(spec)
    if path.is_dir():
        found = sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    elif any(ch in spec for ch in "*?["):
        found = sorted(Path(p) for p in glob.glob(spec) if Path(p).is_file())
    else:
        raise config_error(where, "camera.path", f"{spec} is not a folder of images")
    if not found:
        raise config_error(
            where, "camera.path", f"no images ({', '.join(IMAGE_SUFFIXES)}) in {spec}"
        )
    return found


_REPLAY_PARAMS = (
    Param("loop", "bool", False, doc="start again at the end"),
    Param(
        "pace",
        "str",
        "clock",
        doc="clock: frame i at i/fps s; each: next frame per read",
        choices=("clock", "each"),
    ),
    *INTRINSICS_PARAMS,
)


def _check_fps(fps: Any, where: Any) -> float:
    if not fps > 0:
        raise config_error(where, "camera.fps", f"must be positive, got {fps}")
    return float(fps)


def video_factory(config: dict[str, Any], context: RigContext) -> VideoCamera:
    """Replays a video file as a camera, paced by the run's clock."""
    values, intr, extrinsics, where = camera_config(config, context, _VIDEO_PARAMS)
    path = Path(values["path"])
    if not path.is_file():
        raise config_error(where, "camera.path", f"no video file {path}")
    fps = values["fps"] or video_fps(path) or 30.0
    return VideoCamera(
        path,
        context.clock,
        intr,
        fps=_check_fps(fps, where),
        pace=values["pace"],
        loop=values["loop"],
        mount=values["mount"],
        extrinsics=extrinsics,
    )


# mypy types a def as a plain callable, which has no attributes to set: the same function,
# typed as what it is once PARAMS is set.
video_factory = cast(ComponentFactory[VideoCamera], video_factory)
# a module constant too: in the factory's body mypy still sees the def, without PARAMS
_VIDEO_PARAMS: tuple[Param, ...] = (
    Param("path", "str", doc="video file"),
    Param("fps", "float", None, unit="Hz", doc="replay rate; the file's own rate by default"),
    *_REPLAY_PARAMS,
)
video_factory.PARAMS = _VIDEO_PARAMS


def images_factory(config: dict[str, Any], context: RigContext) -> ImagesCamera:
    """Replays a folder of images (name order) as a camera, paced by the run's clock."""
    values, intr, extrinsics, where = camera_config(config, context, _IMAGES_PARAMS)
    return ImagesCamera(
        image_paths(values["path"], where),
        context.clock,
        intr,
        fps=_check_fps(values["fps"], where),
        pace=values["pace"],
        loop=values["loop"],
        mount=values["mount"],
        extrinsics=extrinsics,
    )


# the same as video_factory's cast above
images_factory = cast(ComponentFactory[ImagesCamera], images_factory)
_IMAGES_PARAMS: tuple[Param, ...] = (
    Param("path", "str", doc="folder of images, or a glob such as frames/*.png"),
    Param("fps", "float", 10.0, unit="Hz", doc="replay rate"),
    *_REPLAY_PARAMS,
)
images_factory.PARAMS = _IMAGES_PARAMS
