"""Appending staged episodes to a LeRobotDataset v3.0 folder.

An append adds one or more episodes at once: their frames to the newest data file,
their camera frames to the newest video file, their rows to the newest episodes
file (each rolled over to a new file when the episode would take it past its size
limit, as LeRobot's recorder does), new tasks, the statistics and the totals. Every
file it changes is written anew and the set replaced as one
(:class:`~.transaction.Transaction`): a full disk, an exception or Ctrl-C before
the commit leaves the dataset exactly as it was, and the episodes are dropped whole.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from armtree.errors import ConfigError

from . import deps, layout, store, video
from . import stats as st
from .episode import Episode
from .lock import DatasetLock
from .transaction import Transaction, recover

_MB = 1024 * 1024
#: What a row of meta/episodes counts towards its file's size limit, bytes.
_ROW_BYTES = 4096


@dataclass
class Appended:
    """What one append did: the episode indices given, and the episodes refused as
    (position in the episodes given, why)."""

    indices: list[int] = field(default_factory=list)
    refused: list[tuple[int, str]] = field(default_factory=list)


class DatasetWriter:
    """The one writer of the dataset at ``root`` (it holds the folder's lock).

    ``fps`` is the rate of the episodes it will append (None: the dataset's own, or
    :data:`~.layout.DEFAULT_FPS` for a new one). Opening refuses, as a
    :class:`ConfigError` at ``where``, a folder another writer holds, a folder holding
    something other than a LeRobot v3.0 dataset, and a dataset at another fps.
    """

    def __init__(self, root: Path, fps: int | None, where: str) -> None:
        deps.require(where)
        self.root = Path(root).absolute()
        self.where = where
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ConfigError(
                f"cannot make the folder ({exc.strerror or exc}); give one you can write to",
                file=where,
            ) from None
        store.open_info(self.root, fps, where)  # refuse before touching anything
        self._lock = DatasetLock(self.root, where)
        try:
            #: What a writer stopped mid-append left behind: ``finished``, ``discarded`` or None.
            self.recovered = recover(self.root)
            info = store.open_info(self.root, fps, where)
        except BaseException:
            self._lock.release()
            raise
        self.fps = int(fps or (info or {}).get("fps") or layout.DEFAULT_FPS)
        shutil.rmtree(self.staging, ignore_errors=True)

    @property
    def staging(self) -> Path:
        """Where this writer's own runs stage their episodes (emptied when it opens)."""
        return self.root / ".staging"

    @property
    def info(self) -> dict[str, Any] | None:
        """meta/info.json as it is now (None before the first episode)."""
        return store.read_info(self.root)

    def close(self) -> None:
        """Remove the staging folder and let other writers in (safe twice)."""
        shutil.rmtree(self.staging, ignore_errors=True)
        self._lock.release()

    # ------------------------------------------------------------------

    def refusal(self, episode: Episode, info: dict[str, Any] | None = None) -> str | None:
        """Why ``episode`` cannot join this dataset, or None when it can."""
        info = self.info if info is None else info
        if episode.fps != self.fps:
            return f"recorded at {episode.fps} fps; the dataset is at {self.fps}"
        if episode.image_shape is not None and episode.video is None:
            return "its camera video is missing"
        if info is None or info.get("total_episodes", 0) == 0:
            return None
        if info.get("robot_type") != episode.robot_type:
            return f"a {episode.robot_type} arm; the dataset records a {info.get('robot_type')}"
        have, want = info["features"], episode.features()
        for key in sorted(set(have) | set(want)):
            a, b = have.get(key), want.get(key)
            if a is None or b is None:
                side = "has no" if b is None else "the dataset has no"
                return f"the episode {side} feature {key}"
            if list(a["shape"]) != list(b["shape"]) or a.get("names") != b.get("names"):
                return (
                    f"{key} is {b.get('names') or b['shape']}; the dataset's is "
                    f"{a.get('names') or a['shape']}"
                )
        return None

    def append(self, episodes: Sequence[Episode]) -> Appended:
        """Append ``episodes`` in order (those that do not fit are refused, the rest go in).

        Raises the :class:`OSError` of a full disk (or any error) with the dataset
        unchanged; the caller says which episodes were dropped.
        """
        done = Appended()
        recover(self.root)  # an append of this writer cut short after its commit
        info = self.info
        accepted: list[Episode] = []
        for position, episode in enumerate(episodes):
            why = self.refusal(episode, info)
            if why is None and info is None and accepted:
                why = self.refusal(episode, _first_info(accepted[0], self.fps))
            if why is not None:
                done.refused.append((position, why))
            else:
                accepted.append(episode)
        if not accepted:
            return done
        txn = Transaction(self.root)
        try:
            done.indices = _Append(self.root, self.fps, txn).run(accepted)
            txn.commit()
        except BaseException:
            txn.abort()
            raise
        return done


def _first_info(episode: Episode, fps: int) -> dict[str, Any]:
    info = layout.new_info(fps, episode.robot_type, episode.features())
    info["total_episodes"] = 1
    return info


class _Append:
    """One append's plan and the new versions of the files it changes."""

    def __init__(self, root: Path, fps: int, txn: Transaction) -> None:
        self.root, self.fps, self.txn = root, fps, txn
        self.pa, self.pq = deps.pyarrow()

    def run(self, episodes: list[Episode]) -> list[int]:
        info = store.read_info(self.root)
        if info is None:
            info = layout.new_info(self.fps, episodes[0].robot_type, episodes[0].features())
            for key in layout.video_keys(info):
                shape = episodes[0].image_shape
                assert shape is not None  # a video feature comes of a camera's images
                height, width = shape[:2]
                info["features"][key]["info"] = layout.video_info(self.fps, height, width)
        self.info = info
        self.keys = layout.video_keys(info)
        last = store.last_episode(self.root)
        tasks = store.read_tasks(self.root)
        n_tasks = len(tasks)
        chunks = int(info["chunks_size"])

        data = _Files(
            self.root, info["data_path"], info["data_files_size_in_mb"], chunks, last, "data"
        )
        metas = _Files(
            self.root,
            layout.EPISODES_PATH,
            info["data_files_size_in_mb"],
            chunks,
            last,
            "meta/episodes",
        )
        videos = {
            key: _Files(
                self.root,
                info["video_path"],
                info["video_files_size_in_mb"],
                chunks,
                last,
                f"videos/{key}",
                video_key=key,
            )
            for key in self.keys
        }
        episode_index = int(info["total_episodes"])
        frame_index = int(last["dataset_to_index"]) if last else 0
        rows, all_stats = [], []
        for episode in episodes:
            if episode.task not in tasks:
                tasks.append(episode.task)
            table = self.frames(episode, episode_index, frame_index, tasks.index(episode.task))
            episode_stats = self.episode_stats(episode, table)
            all_stats.append(episode_stats)
            row = self.row(episode, episode_index, frame_index, episode_stats)
            slot = data.place(table.nbytes, table)
            row.update({"data/chunk_index": slot.chunk, "data/file_index": slot.file})
            for key, files in videos.items():
                row.update(self.video_row(key, files, episode))
            # An episode's row is a few kilobytes, most of it statistics.
            slot = metas.place(_ROW_BYTES, row)
            row.update(
                {"meta/episodes/chunk_index": slot.chunk, "meta/episodes/file_index": slot.file}
            )
            row.update({key: episode.tags.get(key.split("/", 1)[1]) for key in layout.TAGS})
            rows.append(_in_lerobot_order(row))
            episode_index += 1
            frame_index += episode.length

        self.write_data(data)
        for files in videos.values():
            self.write_videos(files)
        self.write_meta(metas, rows)
        if len(tasks) != n_tasks:
            self.pq.write_table(store.tasks_table(tasks), self.txn.path(layout.TASKS_PATH))
        self.write_stats(all_stats)
        info["total_episodes"] = episode_index
        info["total_frames"] = frame_index
        info["total_tasks"] = len(tasks)
        info["splits"] = {"train": f"0:{episode_index}"}
        self.txn.write_json(layout.INFO_PATH, info)
        return [row["episode_index"] for row in rows]

    def row(
        self, episode: Episode, index: int, start: int, episode_stats: dict[str, st.Stats]
    ) -> dict[str, Any]:
        """The episode's row of meta/episodes, in LeRobot's column order (the files' columns
        are added as they are placed)."""
        row: dict[str, Any] = {
            "episode_index": index,
            "tasks": [episode.task],
            "length": episode.length,
            "dataset_from_index": start,
            "dataset_to_index": start + episode.length,
        }
        for feature, values in episode_stats.items():
            for name in layout.STAT_NAMES:
                row[f"stats/{feature}/{name}"] = np.asarray(values[name]).tolist()
        return row

    def video_row(self, key: str, files: _Files, episode: Episode) -> dict[str, Any]:
        """Where the episode's video goes: its file, and the seconds it spans in it."""
        assert episode.video is not None  # refused before: "its camera video is missing"
        slot = files.place(Path(episode.video).stat().st_size, episode.video)
        start = files.seconds.get(slot, 0.0)
        end = files.seconds[slot] = start + episode.length / self.fps
        return {
            f"videos/{key}/chunk_index": slot.chunk,
            f"videos/{key}/file_index": slot.file,
            f"videos/{key}/from_timestamp": start,
            f"videos/{key}/to_timestamp": end,
        }

    # -- one episode --------------------------------------------------------

    def frames(self, episode: Episode, episode_index: int, start: int, task_index: int) -> Any:
        """The episode's rows of the data file."""
        pa = self.pa
        n, width = episode.state.shape
        vector = pa.list_(pa.float32(), width)

        def vectors(values: np.ndarray) -> Any:
            flat = pa.array(np.ascontiguousarray(values, dtype=np.float32).reshape(-1))
            return pa.FixedSizeListArray.from_arrays(flat, width)

        frame = np.arange(n, dtype=np.int64)
        columns = {
            layout.STATE: vectors(episode.state),
            layout.ACTION: vectors(episode.action),
            "timestamp": pa.array((frame / self.fps).astype(np.float32)),
            "frame_index": pa.array(frame),
            "episode_index": pa.array(np.full(n, episode_index, dtype=np.int64)),
            "index": pa.array(start + frame),
            "task_index": pa.array(np.full(n, task_index, dtype=np.int64)),
        }
        schema = pa.schema(
            [(layout.STATE, vector), (layout.ACTION, vector)]
            + [(k, pa.float32() if k == "timestamp" else pa.int64()) for k in list(columns)[2:]]
        )
        return pa.table(columns, schema=schema)

    def episode_stats(self, episode: Episode, table: Any) -> dict[str, st.Stats]:
        """The episode's statistics, feature by feature (info.json's order)."""
        out: dict[str, st.Stats] = {}
        for key, ft in self.info["features"].items():
            if ft["dtype"] == "video":
                if episode.image_stats is not None:
                    out[key] = episode.image_stats
                continue
            if key == layout.STATE:
                values = episode.state
            elif key == layout.ACTION:
                values = episode.action
            else:
                values = table.column(key).to_numpy()
            out[key] = st.of_values(values)
        return out

    # -- the files ------------------------------------------------------------

    def write_data(self, data: _Files) -> None:
        for slot, tables in data.grouped():
            target = slot.path(self.info["data_path"])
            path = self.txn.path(target)
            old = self.root / target
            schema = tables[0].schema
            with self.pq.ParquetWriter(path, schema, compression="snappy") as out:
                if old.exists():
                    source = self.pq.ParquetFile(old)
                    for group in range(source.num_row_groups):
                        out.write_table(source.read_row_group(group).cast(schema))
                for table in tables:
                    out.write_table(table)  # one row group per episode, as LeRobot writes

    def write_videos(self, files: _Files) -> None:
        for slot, paths in files.grouped():
            target = slot.path(self.info["video_path"], video_key=files.keys["video_key"])
            old = self.root / target
            video.join(([old] if old.exists() else []) + list(paths), self.txn.path(target))

    def write_meta(self, metas: _Files, rows: list[dict[str, Any]]) -> None:
        schema = self.episodes_schema(rows[0])
        for slot, new_rows in metas.grouped():
            target = slot.path(layout.EPISODES_PATH)
            old = self.root / target
            table = self.pa.Table.from_pylist(list(new_rows), schema=schema)
            if old.exists():
                table = self.pa.concat_tables([self.pq.read_table(old).cast(schema), table])
            self.pq.write_table(table, self.txn.path(target), compression="snappy")

    def episodes_schema(self, row: dict[str, Any]) -> Any:
        """Column types of meta/episodes for rows like ``row``."""
        pa = self.pa
        fields = []
        for key, value in row.items():
            if key in layout.TAGS:
                kind = layout.TAGS[key]
                typ = {
                    "int64": pa.int64(),
                    "string": pa.string(),
                    "bool": pa.bool_(),
                    "list<string>": pa.list_(pa.string()),
                }[kind]
            elif key == "tasks":
                typ = pa.list_(pa.string())
            elif key.startswith("stats/"):
                depth = np.asarray(value).ndim
                typ = pa.int64() if key.endswith("/count") else pa.float64()
                for _ in range(depth):
                    typ = pa.list_(typ)
            elif key.endswith("_timestamp"):
                typ = pa.float64()
            else:
                typ = pa.int64()
            fields.append((key, typ))
        return pa.schema(fields)

    def write_stats(self, episode_stats: list[dict[str, st.Stats]]) -> None:
        path = self.root / layout.STATS_PATH
        parts = list(episode_stats)
        if path.exists():
            parts.insert(0, st.from_json(json.loads(path.read_text())))
        self.txn.write_json(layout.STATS_PATH, st.to_json(st.aggregate_all(parts)))


class _Files:
    """The files of one kind an append writes to: the newest one, rolled over when full."""

    def __init__(
        self,
        root: Path,
        template: str,
        limit_mb: float,
        chunks_size: int,
        last: dict[str, Any] | None,
        prefix: str,
        **keys: Any,
    ) -> None:
        self.template, self.limit = template, float(limit_mb) * _MB
        self.chunks_size = chunks_size
        self.keys = keys
        self.items: list[tuple[layout.FileSlot, Any]] = []
        #: For videos: seconds of video in each file so far.
        self.seconds: dict[layout.FileSlot, float] = {}
        if last is None:
            self.slot, self.size = layout.FileSlot(), 0.0
            return
        self.slot = layout.FileSlot(
            int(last[f"{prefix}/chunk_index"]), int(last[f"{prefix}/file_index"])
        )
        path = root / self.slot.path(template, **keys)
        self.size = _size(path, prefix) if path.exists() else 0.0
        if prefix.startswith("videos/"):
            self.seconds[self.slot] = float(last[f"{prefix}/to_timestamp"])

    def place(self, size: float, item: Any) -> layout.FileSlot:
        """The file an item of ``size`` bytes goes to (the next one when it would overflow)."""
        if self.size > 0 and self.size + size >= self.limit:
            self.slot, self.size = self.slot.next(self.chunks_size), 0.0
        self.size += size
        self.items.append((self.slot, item))
        return self.slot

    def grouped(self) -> list[tuple[layout.FileSlot, list[Any]]]:
        """The items of each file, files in order."""
        out: dict[layout.FileSlot, list[Any]] = {}
        for slot, item in self.items:
            out.setdefault(slot, []).append(item)
        return list(out.items())


#: The order of meta/episodes' columns, by their first words (LeRobot's order, then armtree's).
_COLUMN_ORDER = (
    "episode_index",
    "tasks",
    "length",
    "data/",
    "dataset_from_index",
    "dataset_to_index",
    "videos/",
    "stats/",
    "meta/",
    "armtree/",
)


def _in_lerobot_order(row: dict[str, Any]) -> dict[str, Any]:
    """``row`` with its columns in :data:`_COLUMN_ORDER` (stable within each group)."""
    rank = {key: next(i for i, p in enumerate(_COLUMN_ORDER) if key.startswith(p)) for key in row}
    return {key: row[key] for key in sorted(row, key=rank.__getitem__)}


def _size(path: Path, prefix: str) -> float:
    """A file's size as the rollover rule counts it: a parquet file's uncompressed data
    (as LeRobot's ``get_parquet_file_size_in_mb``), a video's bytes."""
    if path.suffix == ".parquet":
        _, pq = deps.pyarrow()
        meta = pq.read_metadata(path)
        return float(
            sum(
                meta.row_group(g).column(c).total_uncompressed_size
                for g in range(meta.num_row_groups)
                for c in range(meta.num_columns)
            )
        )
    return float(path.stat().st_size)


__all__ = ["Appended", "DatasetWriter"]
