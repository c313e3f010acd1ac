"""A dataset folder checked against LeRobotDataset v3.0 as LeRobot's loader reads it.

The checks: info.json has the format's keys and the frame features; the totals agree
with the tasks, the episodes and the frames; episodes and frames are numbered without
gap (``episode_index``, ``index``, ``frame_index``, each episode's
``dataset_from_index`` where the last one ended); every file an episode names exists;
within an episode timestamps step by ``1 / fps`` (within LeRobot's default tolerance,
as its ``check_timestamps_sync``); each video file holds exactly the frames of its
episodes, each at ``from_timestamp + timestamp``; stats.json covers every feature.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import deps, layout, store
from .video import probe

#: LeRobot's default ``tolerance_s`` when it loads a dataset.
TOLERANCE_S = 1e-4
#: Problems of one kind listed before the rest are only counted.
_SHOWN = 5
INFO_KEYS = (
    "codebase_version",
    "fps",
    "features",
    "total_episodes",
    "total_frames",
    "total_tasks",
    "chunks_size",
    "data_path",
    "splits",
)


@dataclass
class Report:
    """What :func:`check` found: ``problems`` (empty: the folder is a valid dataset)."""

    root: Path
    problems: list[str] = field(default_factory=list)
    episodes: int = 0
    frames: int = 0
    videos: int = 0

    def add(self, problem: str) -> None:
        """Note one problem."""
        self.problems.append(problem)


def check(root: Path) -> Report:
    """Every check of the module docstring on the dataset at ``root``."""
    root = Path(root)
    report = Report(root)
    try:
        info = store.read_info(root)
    except (OSError, ValueError) as exc:
        report.add(f"{layout.INFO_PATH}: cannot be read ({exc})")
        return report
    if info is None:
        report.add(f"{layout.INFO_PATH}: missing; this is not a LeRobot dataset")
        return report
    missing = [k for k in INFO_KEYS if k not in info]
    if missing:
        report.add(f"{layout.INFO_PATH}: lacks {', '.join(missing)}")
        return report
    if info["codebase_version"] != layout.CODEBASE_VERSION:
        report.add(
            f"{layout.INFO_PATH}: codebase_version {info['codebase_version']!r}, "
            f"not {layout.CODEBASE_VERSION!r}"
        )
        return report
    for key in layout.DEFAULT_FEATURES:
        if key not in info["features"]:
            report.add(f"{layout.INFO_PATH}: the feature {key} is missing")
    for key, ft in info["features"].items():
        if not {"dtype", "shape", "names"} <= set(ft):
            report.add(f"{layout.INFO_PATH}: feature {key} lacks dtype, shape or names")
    fps = info["fps"]
    if not isinstance(fps, int) or fps <= 0:
        report.add(f"{layout.INFO_PATH}: fps {fps!r} is not a positive whole number")
        return report
    tasks = store.read_tasks(root)
    if len(tasks) != info["total_tasks"]:
        report.add(f"total_tasks {info['total_tasks']}, but meta/tasks.parquet has {len(tasks)}")
    episodes = store.read_episodes(root)
    rows = episodes.to_pylist() if episodes is not None else []
    report.episodes = len(rows)
    _check_episodes(report, info, rows, len(tasks))
    data = store.read_data(root)
    report.frames = 0 if data is None else data.num_rows
    _check_frames(report, info, rows, data)
    _check_videos(report, root, info, rows)
    _check_stats(report, root, info)
    return report


def _check_episodes(report: Report, info: dict[str, Any], rows: list[dict], n_tasks: int) -> None:
    if len(rows) != info["total_episodes"]:
        report.add(f"total_episodes {info['total_episodes']}, but meta/episodes has {len(rows)}")
    end = 0
    for i, row in enumerate(rows):
        name = f"episode {row.get('episode_index')}"
        if row.get("episode_index") != i:
            report.add(f"{name}: episode_index {row.get('episode_index')} where {i} is due")
        if row.get("dataset_from_index") != end:
            report.add(f"{name}: dataset_from_index {row.get('dataset_from_index')}, not {end}")
        length = row.get("length")
        if row.get("dataset_to_index", 0) - row.get("dataset_from_index", 0) != length:
            report.add(f"{name}: length {length} disagrees with its from/to indices")
        end = row.get("dataset_to_index", end)
        for task in row.get("tasks") or []:
            if not isinstance(task, str):
                report.add(f"{name}: a task that is not text: {task!r}")
        path = Path(report.root) / layout.FileSlot(
            row["data/chunk_index"], row["data/file_index"]
        ).path(info["data_path"])
        if not path.is_file():
            report.add(f"{name}: its data file {path.relative_to(report.root)} is missing")
    if end != info["total_frames"]:
        report.add(f"total_frames {info['total_frames']}, but the episodes cover {end}")
    if info.get("splits", {}).get("train") not in (None, f"0:{len(rows)}") and rows:
        report.add(f"splits: train is {info['splits']['train']!r}, not '0:{len(rows)}'")


def _check_frames(report: Report, info: dict[str, Any], rows: list[dict], data: Any) -> None:
    if data is None:
        if info["total_frames"]:
            report.add("data/: no data file, but total_frames is " + str(info["total_frames"]))
        return
    if data.num_rows != info["total_frames"]:
        report.add(f"total_frames {info['total_frames']}, but data/ holds {data.num_rows} frames")
    for key, ft in info["features"].items():
        if ft["dtype"] != "video" and key not in data.column_names:
            report.add(f"data/: the feature {key} has no column")
    if not {"index", "episode_index", "frame_index", "timestamp"} <= set(data.column_names):
        return
    index = data.column("index").to_numpy()
    order = np.argsort(index, kind="stable")
    index = index[order]
    if not np.array_equal(index, np.arange(len(index))):
        gaps = np.nonzero(index != np.arange(len(index)))[0]
        report.add(
            f"data/: index is not 0..{len(index) - 1} without gap (first off at row {gaps[0]})"
        )
        return
    episode = data.column("episode_index").to_numpy()[order]
    frame = data.column("frame_index").to_numpy()[order]
    stamps = data.column("timestamp").to_numpy()[order].astype(np.float64)
    fps = info["fps"]
    bad_frames, bad_times = [], []
    for row in rows:
        lo, hi = row["dataset_from_index"], row["dataset_to_index"]
        if hi > len(index) or np.any(episode[lo:hi] != row["episode_index"]):
            report.add(f"episode {row['episode_index']}: its frames are not rows {lo}..{hi - 1}")
            continue
        if not np.array_equal(frame[lo:hi], np.arange(hi - lo)):
            bad_frames.append(row["episode_index"])
        steps = np.diff(stamps[lo:hi])
        if len(steps) and np.max(np.abs(steps - 1.0 / fps)) > TOLERANCE_S:
            bad_times.append(row["episode_index"])
    if bad_frames:
        report.add(f"frame_index is not 0, 1, ... in episodes {_few(bad_frames)}")
    if bad_times:
        report.add(
            f"timestamps do not step by 1/{fps} s (within {TOLERANCE_S} s) in episodes "
            f"{_few(bad_times)}"
        )
    if "task_index" in data.column_names:
        tasks = data.column("task_index").to_numpy()
        if len(tasks) and (tasks.min() < 0 or tasks.max() >= info["total_tasks"]):
            report.add(f"data/: a task_index outside 0..{info['total_tasks'] - 1}")


def _check_videos(report: Report, root: Path, info: dict[str, Any], rows: list[dict]) -> None:
    fps = info["fps"]
    for key in layout.video_keys(info):
        per_file: dict[layout.FileSlot, list[dict]] = {}
        for row in rows:
            if f"videos/{key}/chunk_index" not in row:
                report.add(f"episode {row['episode_index']}: no video of {key}")
                continue
            slot = layout.FileSlot(
                row[f"videos/{key}/chunk_index"], row[f"videos/{key}/file_index"]
            )
            per_file.setdefault(slot, []).append(row)
        for slot, episodes in per_file.items():
            path = root / slot.path(info["video_path"], video_key=key)
            name = str(path.relative_to(root))
            if not path.is_file():
                report.add(f"{name}: missing")
                continue
            report.videos += 1
            _check_stream(report, name, path, info["features"][key].get("info") or {})
            times = _packet_times(path)
            expected = sum(e["length"] for e in episodes)
            if len(times) != expected:
                report.add(f"{name}: {len(times)} frames, but its episodes have {expected}")
                continue
            start = 0.0
            for e in episodes:
                lo, hi = e[f"videos/{key}/from_timestamp"], e[f"videos/{key}/to_timestamp"]
                if abs(lo - start) > TOLERANCE_S or abs(hi - lo - e["length"] / fps) > TOLERANCE_S:
                    report.add(
                        f"{name}: episode {e['episode_index']} spans {lo:.4f}-{hi:.4f} s; "
                        f"{start:.4f}-{start + e['length'] / fps:.4f} s is due"
                    )
                start = hi
            due = np.arange(len(times)) / fps
            off = np.nonzero(np.abs(np.asarray(times) - due) > TOLERANCE_S)[0]
            if len(off):
                report.add(
                    f"{name}: frame {off[0]} is shown at {times[off[0]]:.4f} s, not {due[off[0]]:.4f} s"
                )


#: What a video's stream must agree on with its feature's ``info`` (as LeRobot reads it).
STREAM_FIELDS = ("codec", "width", "height", "pix_fmt")


def _check_stream(report: Report, name: str, path: Path, said: dict[str, Any]) -> None:
    """The stream's codec, size and pixel format against what info.json says of them."""
    found = probe(path)
    for part in STREAM_FIELDS:
        due = said.get(f"video.{part}")
        if due is not None and found[part] != due:
            report.add(f"{name}: {part} {found[part]}, but info.json says {due}")


def _packet_times(path: Path) -> list[float]:
    """Each frame's presentation time (s), from the packets (no decoding)."""
    av = deps.av()
    with av.open(str(path)) as source:
        stream = source.streams.video[0]
        base = float(stream.time_base)
        pts = [p.pts for p in source.demux(stream) if p.pts is not None]
    return sorted(p * base for p in pts)


def _check_stats(report: Report, root: Path, info: dict[str, Any]) -> None:
    path = root / layout.STATS_PATH
    if not path.is_file():
        if info["total_episodes"]:
            report.add(f"{layout.STATS_PATH}: missing")
        return
    data = json.loads(path.read_text())
    for key, ft in info["features"].items():
        entry = data.get(key)
        if entry is None:
            report.add(f"{layout.STATS_PATH}: no statistics of {key}")
            continue
        if not set(layout.STAT_NAMES) <= set(entry):
            report.add(f"{layout.STATS_PATH}: {key} lacks {set(layout.STAT_NAMES) - set(entry)}")
        elif ft["dtype"] not in ("video", "image") and entry["count"] != [info["total_frames"]]:
            # images are counted by the frames sampled for their statistics
            report.add(
                f"{layout.STATS_PATH}: {key} counts {entry['count']} frames of {info['total_frames']}"
            )


def _few(items: list[Any]) -> str:
    shown = ", ".join(str(i) for i in items[:_SHOWN])
    return shown + (f" and {len(items) - _SHOWN} more" if len(items) > _SHOWN else "")


__all__ = ["TOLERANCE_S", "Report", "check"]
