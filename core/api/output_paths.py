"""Where a command writes: an output folder or file the user named, checked before any work.

Every command that writes (``run-tree --record``, ``armtree sweep --out``, ``armtree
detect --annotate``, ``armtree markers -o``, ``armtree show -o``) checks its path here,
so a bad one is a :class:`ConfigError` naming the option and the path (exit 2) with
what is wrong and what to do, before a run starts or an image is drawn: an empty
name, a file or device where a folder is wanted, a folder under a file, one that
cannot be written, one holding an earlier result (refused unless ``overwrite``).

:func:`path_kind` (armtree.config.resolve) names what a path is in these messages.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Sequence
from pathlib import Path

from armtree.config.resolve import path_kind
from armtree.errors import ConfigError


def _under_a_file(path: Path) -> Path | None:
    """The nearest existing ancestor of ``path`` when it is not a folder (a file, a device)."""
    for parent in path.parents:
        if parent.exists() or parent.is_symlink():
            return None if parent.is_dir() else parent
    return None


def _where(option: str, value: str) -> str:
    return f"{option} {value}" if value else f"{option} ''"


def output_folder(
    value: str, option: str, held: Sequence[str] = (), overwrite: bool = False, what: str = "result"
) -> Path:
    """The folder ``value`` given with ``option``, created and checked writable.

    ``held``: names of entries that mark the folder as holding an earlier ``what`` (a run,
    a sweep); when any exists it is refused unless ``overwrite``, and with it those
    entries are removed (:func:`clear_held`; a writer that locks the folder first calls
    that itself, after taking the lock). A :class:`ConfigError` at ``option value``.
    """
    where = _where(option, value)
    if not value.strip():
        raise ConfigError("an empty folder name: give the folder to write into", file=where)
    out = Path(value)
    kind = path_kind(out)
    if kind not in ("nothing", "a folder"):
        raise ConfigError(f"{kind}, not a folder: give a folder to write into", file=where)
    blocker = _under_a_file(out)
    if blocker is not None:
        raise ConfigError(
            f"cannot write there ({blocker} is {path_kind(blocker)}, not a folder); "
            "give a folder you can write to",
            file=where,
        )
    try:
        out.mkdir(parents=True, exist_ok=True)
        if not os.access(out, os.W_OK | os.X_OK):
            reason = "Read-only file system" if _read_only_fs(out) else "Permission denied"
            raise OSError(0, reason)
    except OSError as exc:
        raise ConfigError(
            f"cannot write there ({exc.strerror or exc}); give a folder you can write to",
            file=where,
        ) from None
    clear_held(out, held, overwrite, where, what)
    return out


def clear_held(
    out: Path, held: Sequence[str], overwrite: bool, where: str, what: str = "result"
) -> None:
    """Refuse the folder ``out`` when it holds any of ``held`` (an earlier ``what``), or
    with ``overwrite`` remove those entries; a :class:`ConfigError` at ``where``."""
    found = [name for name in held if (out / name).exists() or (out / name).is_symlink()]
    if found and not overwrite:
        raise ConfigError(
            f"already holds a {what} ({', '.join(found)}); give another folder, "
            "or --overwrite to replace it",
            file=where,
        )
    try:
        for name in found:
            target = out / name
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target)
            else:
                target.unlink()
    except OSError as exc:
        raise ConfigError(
            f"cannot replace the {what} there ({exc.strerror or exc}); give another folder",
            file=where,
        ) from None


def output_file(value: str, option: str) -> Path:
    """The file ``value`` given with ``option``, checked writable before anything is drawn.

    A regular file already there is replaced (the user named it); a folder, a device or a
    FIFO there, a folder that does not exist or is a file, or one that cannot be written
    is a :class:`ConfigError` at ``option value``.
    """
    where = _where(option, value)
    if not value.strip():
        raise ConfigError("an empty file name: give the file to write", file=where)
    out = Path(value)
    kind = path_kind(out)
    if kind not in ("nothing", "a file"):
        raise ConfigError(f"{kind}, not a file: give a file name to write", file=where)
    parent = out.parent
    blocker = _under_a_file(out)
    if blocker is not None:
        raise ConfigError(
            f"cannot write there ({blocker} is {path_kind(blocker)}, not a folder); "
            "give a file in a folder you can write to",
            file=where,
        )
    if path_kind(parent) == "nothing":
        raise ConfigError(
            f"no folder {parent}: create it first, or give a file in a folder that exists",
            file=where,
        )
    if not os.access(out if kind == "a file" else parent, os.W_OK):
        reason = "Read-only file system" if _read_only_fs(parent) else "Permission denied"
        raise ConfigError(
            f"cannot write there ({reason}); give a file where you can write", file=where
        )
    return out


def _read_only_fs(folder: Path) -> bool:
    try:
        return bool(os.statvfs(folder).f_flag & os.ST_RDONLY)
    except OSError:
        return False


__all__ = ["clear_held", "output_file", "output_folder"]
