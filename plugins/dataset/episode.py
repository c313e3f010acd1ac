"""A recorded episode, staged in a folder of its own until a writer appends it.

A folder holds ``episode.json`` (what the episode is: fps, task, joints, camera size,
tags, image statistics), ``arrays.npz`` (``observation.state`` and ``action``, one row
per frame) and ``camera.mp4``. It is written as ``NAME.partial`` and renamed to
``NAME`` when complete, so a folder without the suffix is always whole: a run killed
while staging leaves only a ``.partial`` folder, which nobody appends.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import layout, stats

PARTIAL = ".partial"
VIDEO_FILE = "camera.mp4"


@dataclass
class Episode:
    """One run's frames at the dataset's fps, and what identifies the run.

    ``state`` and ``action`` are ``(frames, joints + 2)`` float32: joint positions
    (degrees / mm), suction (0 or 1) and gripper opening; ``video`` is the camera's
    MP4 with one frame per row (None when the rig has no camera), ``image_shape``
    its (height, width, 3). ``tags`` are the ``armtree/...`` columns of the episode.
    """

    fps: int
    task: str
    robot_type: str | None
    joints: list[str]
    state: np.ndarray
    action: np.ndarray
    video: Path | None = None
    image_shape: tuple[int, int, int] | None = None
    image_stats: dict[str, np.ndarray] | None = None
    tags: dict[str, Any] = field(default_factory=dict)

    @property
    def length(self) -> int:
        """Frames in the episode."""
        return len(self.state)

    def features(self) -> dict[str, Any]:
        """The features a dataset holding this episode has."""
        return layout.features(self.joints, self.image_shape)

    def stage(self, folder: Path) -> Path:
        """Write the episode into ``folder``, by way of ``folder.partial``; the folder."""
        folder = Path(folder)
        partial = folder.with_name(folder.name + PARTIAL)
        partial.mkdir(parents=True, exist_ok=True)  # a recorder may have made it for the video
        np.savez(partial / "arrays.npz", state=self.state, action=self.action)
        if self.video is not None and Path(self.video) != partial / VIDEO_FILE:
            shutil.move(str(self.video), partial / VIDEO_FILE)
        meta = {
            "fps": self.fps,
            "task": self.task,
            "robot_type": self.robot_type,
            "joints": self.joints,
            "length": self.length,
            "video": self.video is not None,
            "image_shape": list(self.image_shape) if self.image_shape else None,
            "image_stats": None
            if self.image_stats is None
            else stats.to_json({"i": self.image_stats})["i"],
            "tags": self.tags,
        }
        (partial / "episode.json").write_text(json.dumps(meta, indent=1))
        if folder.exists():
            shutil.rmtree(folder)
        partial.rename(folder)
        if self.video is not None:
            self.video = folder / VIDEO_FILE
        return folder


def load(folder: Path) -> Episode:
    """The episode staged in ``folder``."""
    folder = Path(folder)
    meta = json.loads((folder / "episode.json").read_text())
    with np.load(folder / "arrays.npz") as arrays:
        state, action = arrays["state"], arrays["action"]
    image_stats = meta.get("image_stats")
    return Episode(
        fps=int(meta["fps"]),
        task=str(meta["task"]),
        robot_type=meta.get("robot_type"),
        joints=list(meta["joints"]),
        state=state,
        action=action,
        video=folder / VIDEO_FILE if meta.get("video") else None,
        image_shape=tuple(meta["image_shape"]) if meta.get("image_shape") else None,
        image_stats=None if image_stats is None else stats.from_json({"i": image_stats})["i"],
        tags=dict(meta.get("tags") or {}),
    )


def is_staged(folder: Path) -> bool:
    """True when ``folder`` holds a whole staged episode."""
    return (Path(folder) / "episode.json").is_file() and not folder.name.endswith(PARTIAL)


__all__ = ["PARTIAL", "Episode", "is_staged", "load"]
