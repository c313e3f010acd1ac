"""One writer per dataset folder: a :class:`FolderLock` on ``DIR/.armtree-writer.lock``."""

from __future__ import annotations

from pathlib import Path

from armtree.api.folder_lock import FolderLock

LOCK_FILE = ".armtree-writer.lock"


class DatasetLock(FolderLock):
    """Holds the writer's lock of one dataset folder until :meth:`release`."""

    def __init__(self, root: Path, where: str) -> None:
        super().__init__(
            root,
            where,
            LOCK_FILE,
            "two writers would mix their episodes: wait for it to end, or give another folder",
        )


__all__ = ["LOCK_FILE", "DatasetLock"]
