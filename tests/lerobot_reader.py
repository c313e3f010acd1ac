"""A small reader of LeRobotDataset v3.0, written from LeRobot's published format alone
(pyarrow and PyAV, no armtree code): what a LeRobot user's loader does with a folder.

``item(i)`` follows ``LeRobotDataset.__getitem__``: the frame's row from the data files,
its episode's row from meta/episodes, the task from meta/tasks.parquet by task_index,
and the camera image decoded from the episode's video file at ``from_timestamp +
timestamp``, which must be within ``tolerance_s`` of a frame (LeRobot's default 1e-4 s).
"""

from __future__ import annotations

import json
from pathlib import Path

import av
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq


class LeRobotReader:
    """One dataset folder opened for reading."""

    def __init__(self, root: Path, tolerance_s: float = 1e-4) -> None:
        self.root = Path(root)
        self.tolerance_s = tolerance_s
        self.info = json.loads((self.root / "meta/info.json").read_text())
        assert self.info["codebase_version"] == "v3.0"
        self.fps = self.info["fps"]
        tasks = pq.read_table(self.root / "meta/tasks.parquet")
        index_column = json.loads(tasks.schema.metadata[b"pandas"])["index_columns"][0]
        self.tasks = dict(
            zip(
                tasks.column("task_index").to_pylist(),
                tasks.column(index_column).to_pylist(),
                strict=True,
            )
        )
        meta = sorted((self.root / "meta/episodes").glob("*/*.parquet"))
        self.episodes = pa.concat_tables([pq.read_table(p) for p in meta]).to_pylist()
        self.episodes.sort(key=lambda e: e["episode_index"])
        data = sorted((self.root / "data").glob("*/*.parquet"))
        self.frames = pa.concat_tables([pq.read_table(p) for p in data]).to_pylist()
        self.video_keys = [k for k, f in self.info["features"].items() if f["dtype"] == "video"]
        self._decoded: dict[Path, list[tuple[float, np.ndarray]]] = {}

    def __len__(self) -> int:
        return len(self.frames)

    def video_path(self, episode: dict, key: str) -> Path:
        return self.root / self.info["video_path"].format(
            video_key=key,
            chunk_index=episode[f"videos/{key}/chunk_index"],
            file_index=episode[f"videos/{key}/file_index"],
        )

    def decoded(self, path: Path) -> list[tuple[float, np.ndarray]]:
        """Every frame of a video file with its time (s), RGB."""
        if path not in self._decoded:
            with av.open(str(path)) as container:
                self._decoded[path] = [
                    (float(f.time), f.to_ndarray(format="rgb24")) for f in container.decode(video=0)
                ]
        return self._decoded[path]

    def image(self, episode: dict, key: str, timestamp: float) -> np.ndarray:
        """The frame of ``key`` shown at the episode's ``timestamp``."""
        query = episode[f"videos/{key}/from_timestamp"] + timestamp
        frames = self.decoded(self.video_path(episode, key))
        times = np.array([t for t, _ in frames])
        nearest = int(np.argmin(np.abs(times - query)))
        gap = abs(times[nearest] - query)
        assert gap < self.tolerance_s, f"no frame within {self.tolerance_s} s of {query} s"
        return frames[nearest][1]

    def item(self, i: int) -> dict:
        """Frame ``i`` as LeRobot hands it to a policy (numpy instead of torch)."""
        row = dict(self.frames[i])
        episode = self.episodes[row["episode_index"]]
        assert episode["dataset_from_index"] <= row["index"] < episode["dataset_to_index"]
        for key in self.video_keys:
            row[key] = self.image(episode, key, row["timestamp"])
        row["task"] = self.tasks[row["task_index"]]
        return row
