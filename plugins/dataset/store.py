"""A dataset folder read back with pyarrow: info, tasks, episodes and frames.

Also what makes a folder a dataset armtree may append to (:func:`open_info`): a
folder holding anything else, another format or another fps is refused with a
message that says what it holds and what to do.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from armtree.errors import ConfigError

from . import deps, layout
from .lock import LOCK_FILE
from .transaction import PENDING

#: What armtree itself leaves in a dataset folder besides the dataset.
OWN_ENTRIES = (LOCK_FILE, PENDING, ".staging")
#: The name pandas gives an index it stores as a column; LeRobot's tasks are that index.
INDEX_COLUMN = "__index_level_0__"


def read_info(root: Path) -> dict[str, Any] | None:
    """meta/info.json of the dataset at ``root``, or None when there is none."""
    path = Path(root) / layout.INFO_PATH
    if not path.is_file():
        return None
    return json.loads(path.read_text())


def open_info(root: Path, fps: int | None, where: str) -> dict[str, Any] | None:
    """The info of the dataset at ``root`` that a writer at ``fps`` may append to (None
    for a new or empty folder); a :class:`ConfigError` at ``where`` otherwise."""
    root = Path(root)
    if root.exists() and not root.is_dir():
        raise ConfigError("a file, not a folder: give a folder for the dataset", file=where)
    try:
        info = read_info(root)
    except (OSError, ValueError) as exc:
        raise ConfigError(
            f"{root / layout.INFO_PATH} cannot be read as JSON ({exc}); "
            "is it a LeRobot dataset? give another folder",
            file=where,
        ) from None
    if info is None:
        others = (
            sorted(p.name for p in root.iterdir() if p.name not in OWN_ENTRIES)
            if root.is_dir()
            else []
        )
        if others:
            shown = ", ".join(others[:5]) + (", ..." if len(others) > 5 else "")
            raise ConfigError(
                f"{root} holds files that are not a LeRobot dataset ({shown}); "
                "give an empty or new folder, or one holding a LeRobot v3.0 dataset",
                file=where,
            )
        return None
    version = info.get("codebase_version") if isinstance(info, dict) else None
    if version != layout.CODEBASE_VERSION:
        hint = (
            "convert it with LeRobot's convert_dataset_v21_to_v30 first"
            if isinstance(version, str) and version.startswith("v2")
            else "give another folder"
        )
        raise ConfigError(
            f"{root} holds a dataset of format {version!r}, not LeRobot's "
            f"{layout.CODEBASE_VERSION}; {hint}",
            file=where,
        )
    if fps is not None and info.get("fps") != fps:
        raise ConfigError(
            f"{root} holds a dataset at {info.get('fps')} fps, not {fps}: every episode of a "
            f"dataset has its fps; give --dataset-fps {info.get('fps')} or another folder",
            file=where,
        )
    return info


def tasks_table(tasks: list[str]) -> Any:
    """meta/tasks.parquet's table: the task strings as pandas' index, ``task_index`` beside
    (what LeRobot writes with ``DataFrame.to_parquet``, so pandas reads the index back)."""
    pa, _ = deps.pyarrow()
    table = pa.table(
        {
            "task_index": pa.array(range(len(tasks)), pa.int64()),
            INDEX_COLUMN: pa.array(tasks, pa.string()),
        }
    )
    pandas_meta = {
        "index_columns": [INDEX_COLUMN],
        "column_indexes": [
            {
                "name": None,
                "field_name": None,
                "pandas_type": "unicode",
                "numpy_type": "object",
                "metadata": {"encoding": "UTF-8"},
            }
        ],
        "columns": [
            {
                "name": "task_index",
                "field_name": "task_index",
                "pandas_type": "int64",
                "numpy_type": "int64",
                "metadata": None,
            },
            {
                "name": None,
                "field_name": INDEX_COLUMN,
                "pandas_type": "unicode",
                "numpy_type": "object",
                "metadata": None,
            },
        ],
        "creator": {"library": "pyarrow", "version": pa.__version__},
        "pandas_version": "2.2.3",
    }
    return table.replace_schema_metadata({b"pandas": json.dumps(pandas_meta).encode()})


def read_tasks(root: Path) -> list[str]:
    """The task strings of the dataset at ``root``, in task_index order."""
    _, pq = deps.pyarrow()
    path = Path(root) / layout.TASKS_PATH
    if not path.is_file():
        return []
    table = pq.read_table(path)
    meta = json.loads((table.schema.metadata or {}).get(b"pandas", b"{}") or b"{}")
    index = (meta.get("index_columns") or [INDEX_COLUMN])[0]
    name = index if isinstance(index, str) else INDEX_COLUMN
    if name not in table.column_names:
        name = "task"
    pairs = zip(table.column("task_index").to_pylist(), table.column(name).to_pylist(), strict=True)
    return [task for _, task in sorted(pairs)]


def files(root: Path, folder: str) -> list[Path]:
    """The ``chunk-*/file-*`` files under ``folder`` of the dataset, in order."""
    return sorted((Path(root) / folder).glob("chunk-*/file-*.*"))


def read_episodes(root: Path) -> Any:
    """Every row of meta/episodes as one pyarrow table, in episode_index order (None
    when the dataset has no episode)."""
    pa, pq = deps.pyarrow()
    paths = files(root, layout.EPISODES_DIR)
    if not paths:
        return None
    tables = [pq.read_table(p) for p in paths]
    table = pa.concat_tables(tables, promote_options="default")
    return table.sort_by("episode_index")


def last_episode(root: Path) -> dict[str, Any] | None:
    """The newest episode's row of meta/episodes without its statistics (None when the
    dataset has none): where the next episode's frames, video and row go."""
    _, pq = deps.pyarrow()
    paths = files(root, layout.EPISODES_DIR)
    if not paths:
        return None
    source = pq.ParquetFile(paths[-1])
    columns = [name for name in source.schema_arrow.names if not name.startswith("stats/")]
    table = source.read(columns=columns)
    if table.num_rows == 0:
        return None
    return table.sort_by("episode_index").slice(table.num_rows - 1).to_pylist()[0]


def read_data(root: Path) -> Any:
    """Every frame of the dataset's data files as one pyarrow table (None when none)."""
    pa, pq = deps.pyarrow()
    paths = files(root, "data")
    if not paths:
        return None
    return pa.concat_tables([pq.read_table(p) for p in paths])


__all__ = [
    "INDEX_COLUMN",
    "files",
    "last_episode",
    "open_info",
    "read_data",
    "read_episodes",
    "read_info",
    "read_tasks",
    "tasks_table",
]
