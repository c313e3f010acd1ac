"""``armtree dataset info DIR`` and ``armtree dataset check DIR``.

``info`` prints what a dataset holds: episodes, frames, how many were judged a
success, fps, robot, tasks, the seeds, rigs and trees its episodes came from, and
its features. ``check`` validates it as LeRobot's loader would read it (exit 0, or 2
listing every problem). Both first finish or forget an append a stopped writer left,
unless a writer holds the folder now.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path
from typing import Any

from armtree.errors import ConfigError

from . import deps, layout, store
from .check import check
from .lock import DatasetLock
from .transaction import recover

EXIT_OK, EXIT_INVALID = 0, 2


def _open(root: Path, where: str) -> None:
    """Refuse what is not a dataset; finish a stopped append when nobody writes now."""
    deps.require(where)
    if not root.is_dir():
        raise ConfigError("no such folder", file=where)
    if not (root / layout.INFO_PATH).is_file():
        store.open_info(root, None, where)  # says what the folder holds instead
        raise ConfigError(f"{root} holds no dataset yet (no {layout.INFO_PATH})", file=where)
    try:
        lock = DatasetLock(root, where)
    except ConfigError as busy:
        print(f"note: {busy.message}; reading it as it is now", file=sys.stderr)
        return
    try:
        done = recover(root)
        if done:
            print(f"note: an append cut short was {done}", file=sys.stderr)
    finally:
        lock.release()


def summary(root: Path) -> dict[str, Any]:
    """What ``armtree dataset info`` shows, as data."""
    info = store.read_info(root) or {}
    tasks = store.read_tasks(root)
    episodes = store.read_episodes(root)
    rows = episodes.to_pylist() if episodes is not None else []
    verdicts = Counter(r.get("armtree/verdict") for r in rows if r.get("armtree/verdict"))
    seeds = sorted(r["armtree/seed"] for r in rows if r.get("armtree/seed") is not None)
    per_task = Counter(t for r in rows for t in r.get("tasks") or [])
    size = sum(
        p.stat().st_size for p in root.rglob("*") if p.is_file() and ".pending" not in p.parts
    )
    return {
        "folder": str(root),
        "codebase_version": info.get("codebase_version"),
        "robot_type": info.get("robot_type"),
        "fps": info.get("fps"),
        "episodes": info.get("total_episodes", 0),
        "frames": info.get("total_frames", 0),
        "seconds": info.get("total_frames", 0) / info["fps"] if info.get("fps") else None,
        "verdicts": dict(verdicts),
        "success_share": (verdicts.get("success", 0) / len(rows)) if rows else None,
        "tasks": [{"task": t, "episodes": per_task.get(t, 0)} for t in tasks],
        "seeds": seeds,
        "rigs": sorted({r["armtree/rig"] for r in rows if r.get("armtree/rig")}),
        "trees": sorted({r["armtree/tree"] for r in rows if r.get("armtree/tree")}),
        "features": {
            key: {k: ft.get(k) for k in ("dtype", "shape", "names")}
            for key, ft in (info.get("features") or {}).items()
        },
        "bytes": size,
    }


def _seed_ranges(seeds: list[int]) -> str:
    if not seeds:
        return "none recorded"
    parts, start, prev = [], seeds[0], seeds[0]
    for seed in seeds[1:] + [None]:
        if seed is not None and seed == prev + 1:
            prev = seed
            continue
        parts.append(str(start) if start == prev else f"{start}-{prev}")
        if seed is not None:
            start = prev = seed
    text = ", ".join(parts[:6]) + (", ..." if len(parts) > 6 else "")
    return text + (f" ({len(seeds)} seeds)" if len(seeds) > 1 else "")


def print_summary(data: dict[str, Any]) -> None:
    """``info``'s text."""
    print(
        f"{data['folder']}: LeRobotDataset {data['codebase_version']}, "
        f"robot {data['robot_type']}, {data['fps']} fps"
    )
    seconds = data["seconds"] or 0.0
    print(f"episodes: {data['episodes']}  frames: {data['frames']} ({seconds / 60:.1f} min)")
    share = data["success_share"]
    if share is None:
        print("success: no episode says how it was judged")
    else:
        counts = ", ".join(f"{v} {k}" for k, v in sorted(data["verdicts"].items()))
        print(f"success share: {100 * share:.1f} % ({counts})")
    for t in data["tasks"]:
        print(f"task {t['task']!r}: {t['episodes']} episodes")
    print(f"seeds: {_seed_ranges(data['seeds'])}")
    print(f"rigs: {', '.join(data['rigs']) or '-'}  trees: {', '.join(data['trees']) or '-'}")
    print("features:")
    for key, ft in data["features"].items():
        names = ft.get("names")
        shown = (
            ", ".join(names)
            if isinstance(names, list) and key.startswith(("observation.state", "action"))
            else ""
        )
        print(f"  {key:<28} {ft['dtype']:<8} {ft['shape']}" + (f"  {shown}" if shown else ""))
    print(f"size: {data['bytes'] / 1e6:.1f} MB")


class DatasetCommand:
    """``armtree dataset info|check DIR``."""

    help = "show what a LeRobot dataset holds (info), or validate it (check)"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add the subcommands."""
        sub = parser.add_subparsers(dest="dataset_action", metavar="ACTION", required=True)
        info = sub.add_parser("info", help="episodes, frames, success share, fps, features")
        info.add_argument("folder", metavar="DIR", help="the dataset's folder")
        info.add_argument("--json", action="store_true", help="print it as JSON")
        checking = sub.add_parser("check", help="validate against LeRobotDataset v3.0")
        checking.add_argument("folder", metavar="DIR", help="the dataset's folder")

    def run(self, args: argparse.Namespace) -> int:
        """Info or check; the exit code."""
        root = Path(args.folder)
        where = f"armtree dataset {args.dataset_action} {args.folder}"
        _open(root, where)
        if args.dataset_action == "info":
            data = summary(root)
            if args.json:
                print(json.dumps(data, indent=2))
            else:
                print_summary(data)
            return EXIT_OK
        report = check(root)
        if report.problems:
            for problem in report.problems:
                print(f"{root}: {problem}")
            print(f"{root}: {len(report.problems)} problems: not a valid LeRobotDataset v3.0")
            return EXIT_INVALID
        print(
            f"{root}: a valid LeRobotDataset {layout.CODEBASE_VERSION} "
            f"({report.episodes} episodes, {report.frames} frames, {report.videos} video files)"
        )
        return EXIT_OK


__all__ = ["DatasetCommand", "summary"]
