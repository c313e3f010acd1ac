"""One writer per dataset folder: an exclusive ``flock`` on ``DIR/.armtree-writer.lock``.

The lock file says who holds it (process, host, command, since when), so the one
refused can be told. The kernel releases the lock when its holder ends, however it
ends, so a killed sweep never leaves the folder locked.
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

LOCK_FILE = ".armtree-writer.lock"


class DatasetLock:
    """Holds the writer's lock of one dataset folder until :meth:`release`."""

    def __init__(self, root: Path, where: str) -> None:
        self.root = Path(root)
        path = self.root / LOCK_FILE
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            raise ConfigError(
                f"{self.root} is being written by {holder}; two writers would mix their "
                "episodes: wait for it to end, or give another folder",
                file=where,
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


__all__ = ["LOCK_FILE", "DatasetLock"]
