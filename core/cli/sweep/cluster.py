"""Sweeps on a Dask cluster: ``--scheduler tcp://HOST:PORT``.

Start ``dask scheduler`` on one machine and ``dask worker tcp://HOST:PORT`` on
each machine that should run seeds (with armtree and the tree's plugins
installed); the sweep sends each seed to a worker, which runs it in a fresh
process of its own forker (as the local pool does) and sends back the outcome.
Run logs stay on the worker's disk, under the sweep's ``--out`` folder path.
Before anything runs every worker is asked whether it can import armtree and
load the tree: one that cannot is reported once, by address, and gets no seeds.
"""

from __future__ import annotations

import asyncio
import contextlib
import signal
import threading
from concurrent.futures import Future
from typing import TYPE_CHECKING, Any

from distributed.diagnostics.plugin import WorkerPlugin

from .forker import Forker, run_isolated
from .options import check_address
from .task import DIED, Outcome, RunTask, failed_outcome

if TYPE_CHECKING:
    from distributed import Worker

#: How long a scheduler gets to answer (seconds).
CONNECT_S = 5.0
PLUGIN_NAME = "armtree-forker"


class SchedulerUnreachable(RuntimeError):
    """No Dask scheduler answered at the address (exit 3)."""


async def _identity(address: str, timeout: float) -> Any:
    from distributed.comm import connect

    comm = await connect(address, timeout=timeout)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await asyncio.wait_for(comm.read(), timeout)
    finally:
        comm.abort()


def probe_scheduler(address: str, timeout: float = CONNECT_S) -> None:
    """Return when a Dask scheduler answers at ``address`` within ``timeout`` seconds.

    Raises :class:`SchedulerUnreachable` naming the address when nothing answers, when
    what answers does not speak Dask (a web server, the dashboard's port) or is not the
    scheduler (a worker's address). Asked before a ``Client`` exists, because a client
    pointed at something else fails with the other end's bytes read as a message size.
    """
    hint = "start one with `dask scheduler` and point --scheduler at the address it prints"
    try:
        answer = asyncio.run(_identity(address, timeout))
    except (OSError, TimeoutError) as exc:
        raise SchedulerUnreachable(
            f"no Dask scheduler answers at {address} within {timeout:g} s ({exc}); {hint}"
        ) from None
    except Exception as exc:  # noqa: BLE001 - whatever answered is not speaking Dask
        raise SchedulerUnreachable(
            f"something answers at {address} but it is not a Dask scheduler "
            f"({type(exc).__name__} reading its reply; is it the dashboard's port?); {hint}"
        ) from None
    kind = answer.get("type") if isinstance(answer, dict) else None
    if kind != "Scheduler":
        what = f"a Dask {kind}" if kind else "not a Dask scheduler"
        raise SchedulerUnreachable(f"{address} answers but is {what}, not the scheduler; {hint}")


class ForkerPlugin(WorkerPlugin):
    """A Dask worker plugin: the worker's own forker, started with the worker, stopped with it."""

    name = PLUGIN_NAME

    def __init__(self) -> None:
        self.forker: Forker | None = None
        self._lock = threading.Lock()

    def __getstate__(self) -> dict[str, Any]:
        # Sent to the workers before it has a forker; a lock does not travel.
        return {}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__()  # type: ignore[misc]

    def setup(self, worker: Any) -> None:
        """Start the forker (it loads armtree while the worker waits for tasks)."""
        with self._lock:
            if self.forker is None:
                self.forker = Forker()

    def teardown(self, worker: Any) -> None:
        """Stop the forker and whatever still runs."""
        if self.forker is not None:
            self.forker.close()


def _forker_plugin(worker: Worker) -> ForkerPlugin | None:
    """The sweep's plugin on ``worker``; None while it has none."""
    plugin = worker.plugins.get(PLUGIN_NAME)
    if plugin is not None and not isinstance(plugin, ForkerPlugin):
        # Another plugin took the name: refuse rather than run seeds without a forker.
        raise TypeError(
            f"the worker's plugin {PLUGIN_NAME!r} is a {type(plugin).__name__}, "
            "not armtree's ForkerPlugin"
        )
    return plugin


def _forker_here() -> Forker:
    from distributed import get_worker

    worker = get_worker()
    plugin = _forker_plugin(worker)
    if plugin is None:  # the worker joined after the sweep registered its plugin
        plugin = ForkerPlugin()
        worker.plugins[PLUGIN_NAME] = plugin
    plugin.setup(worker)
    assert plugin.forker is not None  # setup() starts one when there is none
    return plugin.forker


def run_on_worker(task: RunTask, run_timeout: float | None) -> Outcome:
    """A Dask task: run one seed in a fresh process on this worker."""
    from distributed import get_worker

    return run_isolated(_forker_here(), task, run_timeout, f"worker {get_worker().address}")


def stop_runs_on_worker() -> int:
    """Halt the runs under way on this worker (SIGTERM); how many there were."""
    from distributed import get_worker

    plugin = _forker_plugin(get_worker())
    if plugin is None or plugin.forker is None:
        return 0
    pids = plugin.forker.pids()
    plugin.forker.signal_all(signal.SIGTERM)
    return len(pids)


def check_tree_on_worker(task: RunTask) -> str:
    """``"ok"`` when this worker can load the sweep's tree (with its plugins), else why not."""
    from armtree.hooks.plugin_manager import make_plugin_manager
    from armtree.loader.tree_loader import load_tree

    try:
        manager = make_plugin_manager(task.plugins, task.blocked)
        load_tree(task.tree, rig=task.rig, overrides=task.overrides, manager=manager)
    except Exception as exc:  # noqa: BLE001 - reported once, naming the worker
        return f"{type(exc).__name__}: {exc}".strip()
    return "ok"


class DaskPool:
    """Runs on the workers of the Dask scheduler at ``address``.

    Raises :class:`SchedulerUnreachable` when no scheduler answers within a few seconds.
    """

    def __init__(self, address: str, run_timeout: float | None) -> None:
        from distributed import Client

        self.address = check_address(address)
        self.run_timeout = run_timeout
        probe_scheduler(address)
        try:
            self.client = Client(address, timeout=CONNECT_S, set_as_default=False)
        except (OSError, TimeoutError) as exc:
            raise SchedulerUnreachable(
                f"no Dask scheduler answers at {address} within {CONNECT_S:g} s ({exc}); "
                "start one with `dask scheduler` and point --scheduler at the address it prints"
            ) from None
        self.good: list[str] = []
        self.bad: dict[str, str] = {}
        self.capacity = 1 << 30  # Dask queues the seeds itself
        self._futures: list[Any] = []

    def describe(self) -> str:
        """Where the runs go, for the report."""
        return f"Dask scheduler {self.address} ({len(self.good)} worker(s))"

    def preflight(self, task: RunTask) -> dict[str, str]:
        """Ask every worker whether it can import armtree and load the tree.

        Returns ``{worker: problem}`` for those that cannot (they get no seeds).
        """
        import pkgutil

        found = self.client.run(pkgutil.resolve_name, "armtree.__version__", on_error="return")
        for worker, answer in found.items():
            if isinstance(answer, BaseException):
                self.bad[worker] = f"cannot import armtree ({type(answer).__name__}: {answer})"
        candidates = [w for w in found if w not in self.bad]
        if candidates:
            loaded = self.client.run(
                check_tree_on_worker, task, workers=candidates, on_error="return"
            )
            for worker, answer in loaded.items():
                if answer != "ok":
                    self.bad[worker] = f"cannot load the tree: {answer}"
        self.good = [w for w in found if w not in self.bad]
        return dict(self.bad)

    def start(self) -> None:
        """Start a forker on every usable worker (each loads armtree once)."""
        if self.good:
            # A worker that cannot take it starts its forker with its first seed instead.
            with contextlib.suppress(Exception):
                self.client.register_plugin(ForkerPlugin(), name=PLUGIN_NAME)

    def submit(self, task: RunTask) -> Future[Outcome]:
        """Send one seed to the cluster; a worker lost with it is a DIED outcome."""
        result: Future[Outcome] = Future()
        future = self.client.submit(
            run_on_worker,
            task,
            self.run_timeout,
            key=f"armtree-seed-{task.seed}-{task.attempt}",
            pure=False,
            workers=self.good,
            allow_other_workers=False,
        )
        self._futures.append(future)

        def done(f: Any) -> None:
            try:
                result.set_result(f.result())
            except BaseException as exc:  # noqa: BLE001 - KilledWorker, a lost connection, a cancel
                reason = f"the Dask worker running it was lost ({type(exc).__name__}: {exc})"
                result.set_result(failed_outcome(task, DIED, reason))

        future.add_done_callback(done)
        return result

    def stop(self) -> None:
        """Cancel the seeds not started and halt the runs under way on every worker."""
        self.client.cancel(self._futures)
        if self.good:
            self.client.run(stop_runs_on_worker, workers=self.good, on_error="ignore")

    def close(self) -> None:
        """Disconnect from the scheduler (the workers keep running)."""
        self.client.close()
