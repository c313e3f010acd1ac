"""Finding tree and profile files by path or by name.

A name is tried, in order: as a path (absolute, or relative to the working
directory), relative to ``base`` (the directory of the file that refers to it,
for includes and a tree's ``rig:``), then among the files shipped in the
``armtree.trees`` or ``armtree.hardware`` package (found with
:mod:`importlib.resources`, so editable and wheel installs behave alike).
The ``.yaml`` suffix may be left out.
"""

from __future__ import annotations

import importlib.resources
import stat
from pathlib import Path

#: What a kind of file is called in messages, and the package shipping it.
SHIPPED: dict[str, str] = {"tree": "armtree.trees", "profile": "armtree.hardware"}


def shipped_dir(kind: str) -> Path | None:
    """The directory of the shipped files of ``kind`` (``"tree"`` or ``"profile"``)."""
    try:
        root = importlib.resources.files(SHIPPED[kind])
    except ModuleNotFoundError:
        return None
    path = Path(str(root))
    return path if path.is_dir() else None


def candidates(
    name: str | Path, kind: str, base: Path | None = None, base_first: bool = False
) -> list[Path]:
    """Every path tried for ``name``, in order of preference.

    ``base_first`` tries ``base`` before the working directory (for includes,
    which are relative to the including file).
    """
    raw = Path(name)
    names = [raw] if raw.suffix in (".yaml", ".yml") else [raw, raw.with_name(raw.name + ".yaml")]
    if raw.is_absolute():
        return names
    local = [base / n for n in names] if base is not None else []
    found = [*local, *names] if base_first else [*names, *local]
    shipped = shipped_dir(kind)
    if shipped is not None:
        found += [shipped / n for n in names]
    return found


def resolve(
    name: str | Path, kind: str, base: Path | None = None, base_first: bool = False
) -> Path | None:
    """The file ``name`` refers to, or ``None`` when no candidate exists.

    A name no file system could hold (empty, thousands of characters, a NUL byte)
    is simply not found.
    """
    if not str(name).strip():
        return None
    try:
        for path in candidates(name, kind, base, base_first):
            if path.is_file():
                return path.resolve()
    except (OSError, ValueError):
        return None
    return None


def path_kind(path: Path | str) -> str:
    """What ``path`` is, in words: "a file", "a folder", "a FIFO", "a device", "a socket",
    "a link to nothing", "nothing" (links are followed; a link to a device is a device)."""
    path = Path(path)
    try:
        mode = path.stat().st_mode
    except (FileNotFoundError, NotADirectoryError):
        return "a link to nothing" if path.is_symlink() else "nothing"
    except OSError as exc:
        return f"unreadable ({exc.strerror or exc})"
    if stat.S_ISREG(mode):
        return "a file"
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def not_a_file(
    name: str | Path, kind: str, base: Path | None = None, base_first: bool = False
) -> str:
    """Why ``name`` was not found when a candidate exists but is no regular file, as
    " (NAME is a FIFO, not a file)"; "" otherwise. For the not-found messages."""
    try:
        for path in candidates(name, kind, base, base_first):
            what = path_kind(path)
            if what not in ("nothing", "a file"):
                return f" ({path} is {what}, not a file)"
    except (OSError, ValueError):
        return ""
    return ""


def available(kind: str) -> list[str]:
    """Names of the shipped files of ``kind``, for did-you-mean messages."""
    shipped = shipped_dir(kind)
    if shipped is None:
        return []
    return sorted(p.stem for p in shipped.glob("*.yaml"))
