"""Fresh processes for runs, cheaply: a process that imported armtree once forks one per run.

Loading armtree and its plugins (OpenCV, SciPy, the arms) takes seconds; a run
often not many more. ``python -m armtree.cli.sweep.forker`` imports everything once
and then, for each task it reads on stdin, forks a child that runs it and exits:
every run gets a process of its own (its own blackboard, plugin manager,
emulators and file descriptors) without paying for the imports again. The
forker is single-threaded, so forking it is safe.

Protocol, one JSON object per line. In: ``{"id": K, "task": {...}}`` (a
:class:`RunTask`). Out: ``{"ready": true}`` once loaded, ``{"id": K, "pid":
P}`` when the child starts, ``{"id": K, "exit": CODE}`` or ``{"id": K,
"signal": SIG}`` when it ends. End of input stops the forker: its children get
SIGTERM (they halt within a tick and exit), then SIGKILL after a grace period.

:class:`Forker` drives one from another process, from any number of threads;
:func:`run_isolated` runs one task through it with a wall-clock limit.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import itertools
import json
import os
import selectors
import signal
import subprocess
import sys
import threading
import time
import traceback
import warnings
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeout
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from .task import (
    DIED,
    ERROR,
    TIMEOUT,
    Outcome,
    RunTask,
    failed_outcome,
    load_key,
    load_task,
    run_task,
)

#: Seconds children get to halt after SIGTERM before SIGKILL.
GRACE_S = 5.0
#: Seconds a forker may take to import armtree and its plugins.
READY_S = 300.0


# ---------------------------------------------------------------------------
# The forker process
# ---------------------------------------------------------------------------


def _preload() -> None:
    """Import what runs need, so children start with it loaded."""
    import numpy.ma  # noqa: F401 - numpy's median imports it on first use, in every run

    from armtree.hooks.plugin_manager import get_plugin_manager
    from armtree.loader import tree_loader  # noqa: F401
    from armtree.runtime import runner  # noqa: F401

    get_plugin_manager().registry  # noqa: B018 - loads every plugin's modules


class _LoadedTrees:
    """The tree of the last task, loaded once in the forker for every child to inherit.

    A sweep runs one tree on one rig: loading it (the plugin manager, the tree and its
    profile checked) in the forker spares every run that work. A load that fails, says
    anything or leaves a thread behind is not kept: the child loads the tree itself, so
    its errors and warnings land in the run's own output as before, and the forker stays
    single-threaded.
    """

    def __init__(self) -> None:
        self._key: tuple | None = None
        self._loaded: tuple[Any, Any] | None = None

    def get(self, task: RunTask) -> tuple[Any, Any] | None:
        """:func:`load_task` of ``task`` if it loads cleanly, else None; first the modules
        the task says its run will import (one that fails is left to the run)."""
        for name in task.preload:
            if name not in sys.modules:
                with contextlib.suppress(Exception):
                    importlib.import_module(name)
        key = load_key(task)
        if key != self._key:
            self._key, self._loaded = key, self._load(task)
        return self._loaded

    @staticmethod
    def _load(task: RunTask) -> tuple[Any, Any] | None:
        said = io.StringIO()
        threads = threading.active_count()
        try:
            with (
                warnings.catch_warnings(record=True) as warned,
                contextlib.redirect_stdout(said),
                contextlib.redirect_stderr(said),
            ):
                warnings.simplefilter("always")
                loaded = load_task(task)
        except Exception:  # noqa: BLE001 - the child loads again and reports it
            return None
        if said.getvalue() or warned or threading.active_count() != threads:
            return None
        return loaded


def _child(task: RunTask, loaded: tuple[Any, Any] | None = None) -> None:
    """In the forked child: run the task, write its outcome, exit with its code."""
    code = 1
    try:
        signal.set_wakeup_fd(-1)
        for sig in (
            signal.SIGCHLD,
            signal.SIGPIPE,
            signal.SIGINT,
            signal.SIGTERM,
            signal.SIGHUP,
            signal.SIGQUIT,
        ):
            signal.signal(sig, signal.SIG_DFL)
        run_dir = Path(task.run_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
        null = os.open(os.devnull, os.O_RDONLY)
        out = os.open(run_dir / "output.txt", os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(null, 0)
        os.dup2(out, 1)
        os.dup2(out, 2)
        try:
            outcome, code = run_task(task, loaded)
        except Exception as exc:  # noqa: BLE001 - the sweep reports it with the seed
            traceback.print_exc()
            outcome = failed_outcome(task, ERROR, f"{type(exc).__name__}: {exc}")
            code = 1
        tmp = task.result_path.with_suffix(".tmp")
        tmp.write_text(json.dumps(outcome))
        tmp.replace(task.result_path)
    finally:
        with contextlib.suppress(Exception):
            sys.stdout.flush()
            sys.stderr.flush()
        os._exit(code)


def serve(stdin: IO[str], stdout: IO[str]) -> None:
    """The forker's loop: fork a child per task line, report pids and exits."""
    read_end, write_end = os.pipe()
    os.set_blocking(read_end, False)
    os.set_blocking(write_end, False)
    signal.signal(signal.SIGCHLD, lambda *_: None)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the sweep decides when runs stop
    signal.set_wakeup_fd(write_end)
    children: dict[int, Any] = {}
    source = stdin.fileno()

    def say(message: dict[str, Any]) -> None:
        stdout.write(json.dumps(message) + "\n")
        stdout.flush()

    def reap() -> None:
        while children:
            try:
                pid, status = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                return
            if pid == 0:
                return
            key = children.pop(pid, None)
            if os.WIFSIGNALED(status):
                say({"id": key, "signal": os.WTERMSIG(status)})
            else:
                say({"id": key, "exit": os.waitstatus_to_exitcode(status)})

    say({"ready": True, "pid": os.getpid()})
    selector = selectors.DefaultSelector()
    selector.register(source, selectors.EVENT_READ)
    selector.register(read_end, selectors.EVENT_READ)
    pending = b""
    open_input = True
    trees = _LoadedTrees()
    while open_input:
        for key, _ in selector.select(timeout=1.0):
            if key.fileobj == read_end:
                with contextlib.suppress(BlockingIOError):
                    os.read(read_end, 4096)
                continue
            data = os.read(source, 65536)
            if not data:
                open_input = False
                break
            pending += data
            *lines, pending = pending.split(b"\n")
            for line in lines:
                message = json.loads(line)
                task = RunTask.from_json(json.dumps(message["task"]))
                loaded = trees.get(task)
                pid = os.fork()
                if pid == 0:
                    selector.close()
                    _child(task, loaded)
                children[pid] = message["id"]
                say({"id": message["id"], "pid": pid})
        reap()
    # Input closed: the sweep is over or was stopped. Children halt on SIGTERM.
    _signal(children, signal.SIGTERM)
    deadline = time.monotonic() + GRACE_S
    while children and time.monotonic() < deadline:
        reap()
        time.sleep(0.05)
    _signal(children, signal.SIGKILL)
    while children:
        reap()
        time.sleep(0.01)


def _signal(children: dict[int, Any], sig: int) -> None:
    for pid in list(children):
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, sig)


def main() -> None:
    """``python -m armtree.cli.sweep.forker``: preload, say ready, serve until stdin closes."""
    _preload()
    serve(sys.stdin, sys.stdout)


# ---------------------------------------------------------------------------
# Driving a forker from the sweep (or from a Dask worker)
# ---------------------------------------------------------------------------


@dataclass
class Child:
    """A run's process: its pid once started, and its exit (code, or minus the signal)."""

    pid: Future
    exit: Future


class Forker:
    """A forker process and the children it started; safe to use from many threads.

    ``log`` receives the forker's own stderr (import errors, crashes); ``env``
    adds environment variables for it and so for every run it forks.
    """

    def __init__(self, log: Path | None = None, env: dict[str, str] | None = None) -> None:
        self._log = open(log, "ab") if log is not None else None  # noqa: SIM115
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "armtree.cli.sweep.forker"],
            env={**os.environ, **(env or {})},
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._log if self._log is not None else subprocess.DEVNULL,
            text=True,
            bufsize=1,
            start_new_session=True,  # Ctrl-C reaches the sweep, which stops the runs itself
        )
        self._ids = itertools.count(1)
        self._lock = threading.Lock()
        self._children: dict[int, Child] = {}
        self._ready: Future = Future()
        self._reader = threading.Thread(target=self._read, name="forker-reader", daemon=True)
        self._reader.start()

    def wait_ready(self, timeout: float = READY_S) -> None:
        """Wait until the forker has loaded armtree; raise RuntimeError if it died instead."""
        try:
            self._ready.result(timeout=timeout)
        except FutureTimeout:
            raise RuntimeError(f"the run process did not start within {timeout:g} s") from None

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            message = json.loads(line)
            if message.get("ready"):
                self._ready.set_result(True)
                continue
            child = self._children.get(message["id"])
            if child is None:
                continue
            if "pid" in message:
                child.pid.set_result(message["pid"])
            else:
                code = message["exit"] if "exit" in message else -message["signal"]
                child.exit.set_result(code)
                with self._lock:
                    self._children.pop(message["id"], None)
        error = RuntimeError(f"the run process exited (status {self.proc.wait()})")
        if not self._ready.done():
            self._ready.set_exception(error)
        with self._lock:
            for child in self._children.values():
                for future in (child.pid, child.exit):
                    if not future.done():
                        future.set_exception(error)
            self._children.clear()

    def start(self, task: RunTask) -> Child:
        """Fork a child for ``task``; its pid and exit arrive on the returned futures."""
        self.wait_ready()
        key = next(self._ids)
        child = Child(Future(), Future())
        with self._lock:
            self._children[key] = child
            assert self.proc.stdin is not None
            self.proc.stdin.write(
                json.dumps({"id": key, "task": json.loads(task.to_json())}) + "\n"
            )
            self.proc.stdin.flush()
        return child

    def pids(self) -> list[int]:
        """Children still running."""
        with self._lock:
            children = list(self._children.values())
        return [c.pid.result() for c in children if c.pid.done() and not c.pid.exception()]

    def signal_all(self, sig: int) -> None:
        """Send ``sig`` to every running child (SIGTERM halts a run within a tick)."""
        for pid in self.pids():
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, sig)

    def close(self) -> None:
        """Stop the forker: its children get SIGTERM, then SIGKILL after a grace period."""
        with contextlib.suppress(Exception):
            assert self.proc.stdin is not None
            self.proc.stdin.close()
        try:
            self.proc.wait(timeout=GRACE_S + 5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        if self._log is not None:
            self._log.close()


def run_isolated(forker: Forker, task: RunTask, run_timeout: float | None, where: str) -> Outcome:
    """Run ``task`` in a fresh child of ``forker``; kill it past ``run_timeout`` wall seconds.

    The outcome is the child's own, or says that it timed out (``TIMEOUT``), died
    (``DIED``: killed by a signal, or gone without an outcome) or could not start.
    ``where`` names the worker, for the report.
    """
    started = time.monotonic()
    Path(task.run_dir).mkdir(parents=True, exist_ok=True)
    with contextlib.suppress(FileNotFoundError):
        task.result_path.unlink()
    try:
        child = forker.start(task)
        pid = child.pid.result(timeout=60)
    except Exception as exc:  # noqa: BLE001 - reported with the seed and the worker
        return failed_outcome(
            task, DIED, f"could not start the run on {where}: {exc}", worker=where
        )
    try:
        code = child.exit.result(timeout=run_timeout)
    except FutureTimeout:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
        code = None
        with contextlib.suppress(Exception):
            child.exit.result(timeout=30)
    except Exception as exc:  # noqa: BLE001 - the forker itself went away
        return failed_outcome(
            task, DIED, f"the run process on {where} went away: {exc}", worker=where
        )
    wall = time.monotonic() - started
    if code is None:
        reason = f"run timeout: killed after {run_timeout:g} s of wall time"
        return failed_outcome(task, TIMEOUT, reason, worker=where, wall_seconds=wall)
    try:
        outcome = json.loads(task.result_path.read_text())
    except (OSError, ValueError):
        how = f"signal {-code}" if code < 0 else f"exit {code} without an outcome"
        return failed_outcome(
            task, DIED, f"the run's process died ({how})", worker=where, wall_seconds=wall
        )
    outcome["worker"] = where
    return outcome


if __name__ == "__main__":
    main()
