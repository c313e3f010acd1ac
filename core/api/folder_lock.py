"""One writer per output folder: an exclusive ``flock`` on a lock file in the folder.

The lock file says who holds it (process, host, command, since when), so the one
refused can be told. The kernel releases the lock when its holder ends, however it
ends, so a killed run never leaves the folder locked. A dataset folder
(``.armtree-writer.lock``) and a run's ``--record`` folder (``.armtree-run.lock``)
are held so.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import socket
import sys
import time
from pathlib import Path

from armtree.errors import ConfigError


class FolderLock:
    """Holds the writer's lock ``root/name`` until :meth:`release`.

    ``where`` is where a refusal points (the option and path); ``why`` ends its message
    (what two writers would do, and what to do instead).
    """

    def __init__(self, root: Path, where: str, name: str, why: str) -> None:
        self.root = Path(root)
        path = self.root / name
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise ConfigError(
                f"cannot write there ({exc.strerror or exc}); give a folder you can write to",
                file=where,
            ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            raise ConfigError(
                f"{self.root} is being written by {holder}; {why}", file=where
            ) from None
        except BaseException:
            os.close(fd)
            raise
        self._fd: int | None = fd
        os.ftruncate(fd, 0)
        os.pwrite(
            fd,
            json.dumps(
                {
                    "pid": os.getpid(),
                    "host": socket.gethostname(),
                    "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]])[:300],
                    "since": time.strftime("%Y-%m-%d %H:%M:%S"),
                }
            ).encode(),
            0,
        )

    def release(self) -> None:
        """Let another writer in (safe twice)."""
        fd, self._fd = self._fd, None
        if fd is not None:
            with contextlib.suppress(OSError):
                os.ftruncate(fd, 0)
            os.close(fd)


def _holder(fd: int) -> str:
    """Who holds the lock, from what it wrote in the file."""
    try:
        data = json.loads(os.pread(fd, 4096, 0).decode() or "{}")
    except (OSError, ValueError):
        data = {}
    if not data:
        return "another process"
    return (
        f"process {data.get('pid')} on {data.get('host')} since {data.get('since')} "
        f"({data.get('command')})"
    )


__all__ = ["FolderLock"]
