"""The local process pool: runs on this machine, each in a fresh child of one forker."""

from __future__ import annotations

import os
import signal
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

from .forker import Forker, run_isolated
from .task import Outcome, RunTask


class LocalPool:
    """``workers`` runs at a time on this machine, each in its own process.

    A thread per slot waits for its child, so a hung run is killed after
    ``run_timeout`` wall seconds without holding up the others. ``log`` gets
    the forker's own error output. With a run on every core, each run's OpenCV
    works on one thread.
    """

    def __init__(self, workers: int, run_timeout: float | None, log: Path | None = None) -> None:
        self.workers = workers
        self.capacity = workers
        self.run_timeout = run_timeout
        self.forker = Forker(log, run_environment(workers))
        self._threads = ThreadPoolExecutor(workers, thread_name_prefix="armtree-sweep")

    def describe(self) -> str:
        """Where the runs go, for the report."""
        return f"{self.workers} local worker{'s' if self.workers != 1 else ''}"

    def start(self) -> None:
        """Wait until the run process has loaded armtree (a few seconds)."""
        self.forker.wait_ready()

    def submit(self, task: RunTask) -> Future[Outcome]:
        """Run ``task`` in a fresh process when a slot is free."""
        where = f"this machine (run process {self.forker.proc.pid})"
        return self._threads.submit(run_isolated, self.forker, task, self.run_timeout, where)

    def stop(self) -> None:
        """Halt the runs under way (SIGTERM: each halts within a tick and flushes its log)."""
        self.forker.signal_all(signal.SIGTERM)

    def close(self) -> None:
        """Wait for the slots, then stop the forker (what still runs gets SIGTERM, then SIGKILL)."""
        self._threads.shutdown(wait=True, cancel_futures=True)
        self.forker.close()


def run_environment(workers: int, cores: int | None = None) -> dict[str, str]:
    """Environment for runs when ``workers`` share ``cores`` (default: this machine's).

    With no core to spare, OpenCV's worker threads only add hand-offs to a run's
    CPU time (detections are the same on any number of threads), so each run gets
    one, unless the user set ``OPENCV_FOR_THREADS_NUM`` already.
    """
    cores = cores or os.cpu_count() or 1
    if workers < cores or "OPENCV_FOR_THREADS_NUM" in os.environ:
        return {}
    return {"OPENCV_FOR_THREADS_NUM": "1"}
