"""Several files of a dataset replaced as one, so that no reader sees half an append.

New versions are written beside the dataset in ``.pending/`` and synced; a journal
naming them is then renamed into place (the commit: one rename, atomic); then each
new file is renamed over the old one and the journal removed. Anything that stops
the writer before the commit (a full disk, Ctrl-C, a killed process) leaves the
dataset as it was and ``.pending/`` to be removed; after the commit the renames are
finished by :func:`recover` before anyone next writes or checks the folder.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
from pathlib import Path

PENDING = ".pending"
JOURNAL = "journal.json"


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


class Transaction:
    """New versions of files under ``root``, committed together or not at all."""

    def __init__(self, root: Path) -> None:
        self.root = Path(root)
        self.folder = self.root / PENDING
        if self.folder.exists():
            shutil.rmtree(self.folder)
        self.folder.mkdir(parents=True)
        #: (file in .pending, path relative to root) of every new version, in order.
        self.entries: list[tuple[str, str]] = []
        #: True once the journal is in place: from then on the new versions are the dataset.
        self.committed = False

    def path(self, target: str) -> Path:
        """Where to write the new version of ``target`` (relative to the root); it is
        committed under that name."""
        name = f"{len(self.entries):04d}-{Path(target).name}"
        self.entries.append((name, target))
        return self.folder / name

    def write_text(self, target: str, text: str) -> None:
        """The new version of ``target`` is ``text``."""
        self.path(target).write_text(text)

    def write_json(self, target: str, data: object) -> None:
        """The new version of ``target`` is ``data`` as indented JSON (LeRobot's layout)."""
        self.write_text(target, json.dumps(data, indent=4, ensure_ascii=False) + "\n")

    def commit(self) -> None:
        """Sync the new versions, commit them with the journal and put them in place."""
        for name, _ in self.entries:
            _fsync(self.folder / name)
        journal = self.folder / (JOURNAL + ".tmp")
        journal.write_text(json.dumps(self.entries))
        _fsync(journal)
        journal.replace(self.folder / JOURNAL)
        self.committed = True
        _fsync(self.folder)
        apply(self.root)

    def abort(self) -> None:
        """Forget the new versions, the dataset staying as it was; after the commit, leave
        them for :func:`recover` (the journal says what is still to be put in place)."""
        if not self.committed:
            shutil.rmtree(self.folder, ignore_errors=True)


def apply(root: Path) -> None:
    """Put a committed transaction's files in place and remove its folder (idempotent)."""
    folder = Path(root) / PENDING
    entries = json.loads((folder / JOURNAL).read_text())
    for name, target in entries:
        source = folder / name
        if source.exists():
            destination = Path(root) / target
            destination.parent.mkdir(parents=True, exist_ok=True)
            source.replace(destination)
    with contextlib.suppress(OSError):
        _fsync(Path(root))
    shutil.rmtree(folder, ignore_errors=True)


def recover(root: Path) -> str | None:
    """Finish or forget a transaction a stopped writer left under ``root``; what was done
    (``"finished"``, ``"discarded"``) or None when there was none."""
    folder = Path(root) / PENDING
    if not folder.exists():
        return None
    if (folder / JOURNAL).exists():
        apply(root)
        return "finished"
    shutil.rmtree(folder, ignore_errors=True)
    return "discarded"


__all__ = ["PENDING", "Transaction", "apply", "recover"]
