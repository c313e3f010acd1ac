"""The LeRobotDataset v3.0 folder as LeRobot lays it out (``lerobot/datasets/utils.py``).

::

    meta/info.json                                  fps, features, totals, path templates
    meta/stats.json                                 per feature: min, max, mean, std, count
    meta/tasks.parquet                              index: the task string; task_index
    meta/episodes/chunk-000/file-000.parquet        one row per episode: where it lives
    data/chunk-000/file-000.parquet                 one row per frame
    videos/observation.images.camera/chunk-000/file-000.mp4

Many episodes share a file; a file is full when the next episode would take it past
its size limit, and a chunk holds ``chunks_size`` files. Nothing here reads or writes
a file: see :mod:`.store` and :mod:`.writer`.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

CODEBASE_VERSION = "v3.0"
#: Files per chunk folder (LeRobot's default).
CHUNKS_SIZE = 1000
#: A data or episodes parquet file, and a video file, is full at this size. LeRobot's
#: recorder uses 100 and 500: it keeps its files open while it records, where an
#: armtree append rewrites the newest files (neither an MP4's index nor a parquet
#: footer can be added to), so smaller files keep each append cheap (a tenth of a
#: second: docs/benchmarks-history.md, "Datasets"). LeRobot reads the limits from info.json.
DATA_FILES_SIZE_IN_MB = 25
VIDEO_FILES_SIZE_IN_MB = 25
#: Frames a second of a new dataset unless ``--dataset-fps`` says otherwise.
DEFAULT_FPS = 10

INFO_PATH = "meta/info.json"
STATS_PATH = "meta/stats.json"
TASKS_PATH = "meta/tasks.parquet"
EPISODES_DIR = "meta/episodes"
CHUNK_FILE = "chunk-{chunk_index:03d}/file-{file_index:03d}"
EPISODES_PATH = EPISODES_DIR + "/" + CHUNK_FILE + ".parquet"
DATA_PATH = "data/" + CHUNK_FILE + ".parquet"
VIDEO_PATH = "videos/{video_key}/" + CHUNK_FILE + ".mp4"

#: The features every frame has, after the recorded ones (LeRobot's DEFAULT_FEATURES).
DEFAULT_FEATURES: dict[str, dict[str, Any]] = {
    "timestamp": {"dtype": "float32", "shape": [1], "names": None},
    "frame_index": {"dtype": "int64", "shape": [1], "names": None},
    "episode_index": {"dtype": "int64", "shape": [1], "names": None},
    "index": {"dtype": "int64", "shape": [1], "names": None},
    "task_index": {"dtype": "int64", "shape": [1], "names": None},
}
STATE = "observation.state"
ACTION = "action"
#: The video feature of the rig's camera.
CAMERA_KEY = "observation.images.camera"

#: Columns armtree adds to each episode's row of ``meta/episodes``: enough to run the
#: episode again (``run-tree TREE --rig RIG --seed SEED --set ...``) and how it was judged.
TAGS = {
    "armtree/seed": "int64",
    "armtree/tree": "string",
    "armtree/rig": "string",
    "armtree/overrides": "list<string>",
    "armtree/verdict": "string",
    "armtree/checked": "bool",
}

#: Statistics kept per feature, in LeRobot's order.
STAT_NAMES = ("min", "max", "mean", "std", "count")


@dataclass(frozen=True)
class FileSlot:
    """Where an episode's rows or frames go: ``chunk-{chunk}/file-{file}``."""

    chunk: int = 0
    file: int = 0

    def next(self, chunks_size: int) -> FileSlot:
        """The file after this one: the next file of the chunk, or the next chunk's first."""
        if self.file >= chunks_size - 1:
            return FileSlot(self.chunk + 1, 0)
        return FileSlot(self.chunk, self.file + 1)

    def path(self, template: str, **keys: Any) -> str:
        """``template`` filled in for this slot."""
        return template.format(chunk_index=self.chunk, file_index=self.file, **keys)


def vector_names(joints: list[str]) -> list[str]:
    """Names of ``observation.state`` and ``action``: each joint's position, then the tool."""
    return [f"{name}.pos" for name in joints] + ["suction", "gripper.pos"]


def features(joints: list[str], image_shape: tuple[int, int, int] | None) -> dict[str, Any]:
    """The ``features`` of info.json for an arm with ``joints`` and a camera of
    ``image_shape`` (height, width, channels; None: no camera)."""
    names = vector_names(joints)
    out: dict[str, Any] = {
        STATE: {"dtype": "float32", "shape": [len(names)], "names": names},
        ACTION: {"dtype": "float32", "shape": [len(names)], "names": names},
    }
    if image_shape is not None:
        out[CAMERA_KEY] = {
            "dtype": "video",
            "shape": list(image_shape),
            "names": ["height", "width", "channels"],
        }
    out.update(copy.deepcopy(DEFAULT_FEATURES))
    return out


def video_info(fps: int, height: int, width: int) -> dict[str, Any]:
    """The ``info`` of a video feature, as LeRobot's ``get_video_info`` writes it."""
    return {
        "video.height": height,
        "video.width": width,
        "video.codec": "h264",
        "video.pix_fmt": "yuv420p",
        "video.is_depth_map": False,
        "video.fps": fps,
        "video.channels": 3,
        "has_audio": False,
    }


def new_info(fps: int, robot_type: str | None, feats: dict[str, Any]) -> dict[str, Any]:
    """info.json of a dataset with no episode yet (LeRobot's ``create_empty_dataset_info``)."""
    has_video = any(ft["dtype"] == "video" for ft in feats.values())
    return {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": robot_type,
        "total_episodes": 0,
        "total_frames": 0,
        "total_tasks": 0,
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": DATA_FILES_SIZE_IN_MB,
        "video_files_size_in_mb": VIDEO_FILES_SIZE_IN_MB,
        "fps": fps,
        "splits": {},
        "data_path": DATA_PATH,
        "video_path": VIDEO_PATH if has_video else None,
        "features": feats,
    }


def video_keys(info: dict[str, Any]) -> list[str]:
    """The features of ``info`` stored as videos."""
    return [key for key, ft in info["features"].items() if ft.get("dtype") == "video"]


__all__ = [
    "ACTION",
    "CAMERA_KEY",
    "CODEBASE_VERSION",
    "DEFAULT_FEATURES",
    "DEFAULT_FPS",
    "STATE",
    "TAGS",
    "FileSlot",
    "features",
    "new_info",
    "vector_names",
    "video_info",
    "video_keys",
]
