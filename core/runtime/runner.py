"""The tick runtime: one run of a tree on a rig, from set-up to a guaranteed clean halt.

:func:`run` is the public entry point; :class:`Run` holds one run's state and is
what lifecycle hooks and behaviours (``self.runtime``) see.

A run:

1. picks a clock (virtual unless ``realtime`` or the profile names real
   hardware), clears py_trees' process-wide blackboard and writes the tree's
   initial values, builds the rig from the profile if none was given;
2. sets every behaviour up with ``rig=``, ``clock=`` and ``runtime=``;
3. ticks at ``tree.tick_hz``: advance the clock, ``rig.step(now)``, tick the
   tree, log status changes and blackboard writes, call ``armtree_tick``;
   between ticks it holds while ``run.control`` (:mod:`armtree.runtime.control`) asks it
   to pause, and on a virtual clock it keeps to ``run.control.speed`` if set;
4. ends on the root's SUCCESS or FAILURE, ``timeout``/``max_ticks`` (FAILURE),
   an exception inside a behaviour (FAILURE, with the node's path and YAML
   position), a component's :meth:`Run.fail` (FAILURE: a collision under
   ``halt_on_collision``) or an interrupt (INTERRUPTED: signal, stop key,
   component event);
5. halts: every RUNNING node is stopped with INVALID (py_trees' own shutdown
   leaves them RUNNING), the arm is told to stop on an abnormal end, behaviours
   whose ``halting()`` says they are still reaching a safe state get more clock
   steps (bounded by ``stop_timeout``), the tree is shut down, the rig closed
   and the log flushed, on every path;
6. is judged: the tree's ``expect:`` on the world's ground truth (when a
   plugin knows it), giving the verdict: a SUCCESS the world disagrees with is
   a false success and exits 1.

:class:`Run` keeps the order of these steps, the tick loop and the interrupts, and
wires the collaborators that do the rest, each with one job: the clock, plugin
manager and run log it starts with (:mod:`armtree.runtime.run_start`), the blackboard
(:mod:`armtree.runtime.blackboard_log`), where each node is (:mod:`armtree.runtime.node_index`),
each node's status (:mod:`armtree.runtime.status_tracking`), why the run ends early
(:mod:`armtree.runtime.failure_report`), when the next tick starts (:mod:`armtree.runtime.pacing`),
pausing (:mod:`armtree.runtime.pausing`), the tick watchdog and forced exits
(:mod:`armtree.runtime.run_watchdog`), a ``--watch`` tree swapped in
(:mod:`armtree.runtime.tree_replacement`), halting (:mod:`armtree.runtime.halting`) and the end:
the result, its judgement and the closing (:mod:`armtree.runtime.run_end`).
"""

from __future__ import annotations

import contextlib
import functools
import sys
import time
import traceback as tb_module
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import py_trees
from py_trees.common import Status

from armtree.api.behaviour import BehaviourRuntime
from armtree.api.clock import Clock
from armtree.api.outcomes.failures import FailureLog
from armtree.api.rig import Rig
from armtree.api.views import ProfileView
from armtree.errors import HardwareFault
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.tree import Tree

from .blackboard_log import BlackboardLog
from .control import RunControl
from .display import NullView, make_view
from .failure_report import (
    EXIT_HARDWARE,
    EXIT_SUCCESS,
    End,
    FailureReport,
)
from .feedback_log import FeedbackLog
from .halting import Halter
from .interrupts import Interrupts, StopKey
from .node_index import NodeIndex
from .pacing import Pacer
from .pausing import POLL_S, RunPause
from .resources import Resources
from .rig_builder import build_rig
from .run_end import (
    RunEnding,
    RunResult,
)
from .run_hooks import RunHooks
from .run_start import choose_clock, choose_record_dir, open_log, plugin_manager
from .run_watchdog import RunWatchdog, profile_tick_limit
from .runlog import RunLog
from .stall_watch import StallWatch, profile_stall_limit
from .status_guard import guard_statuses
from .status_tracking import StatusTracker
from .tree_replacement import TreeReplacement
from .watchdog import TickAbandoned

#: How often the run log is flushed during a run, in wall seconds.
_FLUSH_S = 1.0


class Run:
    """One run of a tree: clock, rig, log, resources, interrupts and the tick loop.

    Construct it and call :meth:`execute` once (or use :func:`run`). Behaviours
    reach it as ``self.runtime``; hooks receive it as ``run``.
    ``close_rig`` defaults to closing only a rig this run built itself.
    """

    def __init__(
        self,
        tree: Tree,
        rig: Rig | None = None,
        *,
        seed: int = 0,
        realtime: bool = False,
        record: Path | str | bool | None = None,
        timeout: float | None = None,
        max_ticks: int | None = None,
        quiet: bool = True,
        manager: PluginManager | None = None,
        stop_timeout: float = 2.0,
        runs_dir: Path | str = "runs",
        handle_signals: bool = True,
        stop_key: bool = True,
        view: Any = None,
        close_rig: bool | None = None,
        debug: bool = False,
        settings: dict[str, Any] | None = None,
        tick_limit: float | None = None,
    ) -> None:
        self.tree = tree
        self.root: py_trees.behaviour.Behaviour = tree.root
        self.tick_hz = float(getattr(tree, "tick_hz", 20.0) or 20.0)
        self.period = 1.0 / self.tick_hz
        self.seed = seed
        self.timeout = timeout
        self.max_ticks = max_ticks
        self.stop_timeout = stop_timeout
        self.debug = debug
        self.manager = manager if manager is not None else getattr(tree, "manager", None)
        self.rig = rig
        self._own_rig = rig is None
        self._close_rig = close_rig
        profile = getattr(tree, "profile", None)
        self.clock: Clock = (
            rig.clock if rig is not None else choose_clock(profile, realtime, self.manager)
        )
        self.tick_count = 0
        self.interrupts = Interrupts(force_exit=self._force_exit)
        #: Pause, step, resume, stop and speed, from any thread (page, keys, tests).
        self.control = RunControl(self.interrupts)
        #: The command-line options that started the run (``{}`` from the API), read by
        #: plugins that added options of their own (``armtree_run_options``).
        self.settings: dict[str, Any] = dict(settings or {})
        #: Called with no argument when the run is over, whatever happened, newest first:
        #: for what a plugin opened in ``armtree_run_opening`` (a server, a watcher).
        self.closers: list[Any] = []
        #: Files of the record that could not be written, ``"name: reason"`` each (a full
        #: disk): plugins writing into the record folder add theirs, up to the closers.
        self.record_errors: list[str] = []
        #: What plugins keep for this run, each under a key of its own (``"monitor"``).
        self.plugin_state: dict[str, Any] = {}
        #: Wall seconds the last tick took: rig step, tree tick, logging, tick hooks.
        self.tick_wall = 0.0
        #: Run time at which the last tick started (the ``t`` of its log records).
        self.tick_time = 0.0
        #: When each tick starts; overruns and, on a wall clock, each tick's lateness.
        self.pacer = Pacer(self.clock, self.period, self.interrupts.wake)
        #: On a wall clock, how late each tick started against its schedule (seconds).
        self.tick_lateness = self.pacer.lateness
        #: Holds the run between ticks while ``control`` asks it to.
        self.pause = RunPause(
            control=self.control, pacer=self.pacer, interrupts=self.interrupts, clock=self.clock
        )
        #: Each node's path and YAML position.
        self.index = NodeIndex(tree)
        #: A validated tree waiting for a safe point to replace the running one (--watch).
        self.replacement = TreeReplacement(self)
        #: Halts the tree's running nodes and waits until they are safe.
        self.halter = Halter(self)
        self._bt: py_trees.trees.BehaviourTree | None = None
        self.resources = Resources(halt=self._halt_owner)
        self.view = view if view is not None else (NullView() if quiet else make_view(False))
        # A view that ignores updates (quiet) is not handed the tick's status changes,
        # so they are not built for it.
        self._view_changes = type(self.view).update is not NullView.update
        self._handle_signals = handle_signals
        self._stop_key = stop_key
        self._key: StopKey | None = None
        self._record = record
        self._runs_dir = Path(runs_dir)
        self.log = RunLog(None)
        self.record_dir: Path | None = None
        #: Every node's status from tick to tick: logged, noted when failing, shown.
        self.status = StatusTracker(self)
        #: Writes the run log's feedback records (replaced with the log in _open_log).
        self.feedback = FeedbackLog(self.log)
        #: The blackboard's initial values and its writes, logged tick by tick.
        self.blackboard = BlackboardLog()
        self.hooks = RunHooks(self)
        self._executed = False
        self._end_status = ""
        self.failures = FailureLog()
        #: Why the run ends early, as records, message, failed node and traceback.
        self.report = FailureReport(
            clock=self.clock,
            interrupts=self.interrupts,
            index=self.index,
            halter=self.halter,
            view=self.view,
            log=self.log,
        )
        #: Notable events components reported, for the summary (the log has them all).
        self.events = self.report.events
        self.tick_limit = tick_limit if tick_limit is not None else profile_tick_limit(profile)
        #: Whether the tree still makes progress (a stall is reported, the run goes on).
        self.stall = StallWatch(profile_stall_limit(profile))
        #: The tick watchdog and the forced exit of a stop that hangs.
        self.watchdog = RunWatchdog(
            limit_s=self.tick_limit,
            stop_timeout=stop_timeout,
            clock=self.clock,
            interrupts=self.interrupts,
            halter=self.halter,
            index=self.index,
            report=self.report,
            tick=lambda: self.tick_count,
        )
        self.ending = RunEnding(
            halter=self.halter,
            report=self.report,
            index=self.index,
            pacer=self.pacer,
            resources=self.resources,
            blackboard=self.blackboard,
            clock=self.clock,
            failures=self.failures,
            stop_timeout=stop_timeout,
        )

    # ------------------------------------------------------------------
    # For behaviours and components
    # ------------------------------------------------------------------

    def claim(self, behaviour: py_trees.behaviour.Behaviour, names: Iterable[str]) -> None:
        """Give ``behaviour`` the resources ``names``, halting their running owner first."""
        for preemption in self.resources.claim(behaviour, names):
            self.log.event(
                self.tick_count,
                self.clock.now(),
                "preempt",
                resource=preemption.resource,
                halted=self.path_of(preemption.previous),
                owner=self.path_of(preemption.owner),
            )

    def interrupt(self, reason: str, fault: HardwareFault | None = None) -> None:
        """Ask the run to halt within one tick; safe from any thread (a RigContext's interrupt)."""
        self.interrupts.request(reason, fault)

    def fail(self, reason: str) -> None:
        """End the run as FAILURE before the tree is ticked again, because of ``reason``.

        For components that see the task fail outright (a collision under
        ``halt_on_collision``); safe from any thread. The first reason given wins.
        """
        self.report.fail(reason)

    def report_event(self, event: str, message: str | None = None, **data: Any) -> None:
        """Write a component's event to the run log at the current tick.

        With a ``message`` (a collision, a drop, a missed step, a fault) it is
        also shown in the live view and listed in the summary. ``data`` are the
        record's fields (JSON-safe values). Call it from the run's thread (a
        stepper or a behaviour).
        """
        self.report.event(self.tick_count, event, message, **data)

    def path_of(self, behaviour: py_trees.behaviour.Behaviour) -> str:
        """The node's path in the tree (``"Root/Branch/Leaf"``), from the loader's NodeInfo if any."""
        return self.index.path_of(behaviour)

    def where(self, behaviour: py_trees.behaviour.Behaviour) -> str:
        """``"path (file:line)"`` of a node, as far as it is known."""
        return self.index.where(behaviour)

    @property
    def nodes(self) -> list[py_trees.behaviour.Behaviour]:
        """Every node of the tree, depth first from the root (the order of :attr:`statuses`)."""
        return self.status.nodes

    @property
    def node_paths(self) -> tuple[str, ...]:
        """Each node's path, in the order of :attr:`nodes`."""
        return self.status.paths

    @property
    def statuses(self) -> tuple[str, ...]:
        """Each node's status name after the last tick, in the order of :attr:`nodes`.

        A new tuple only when some status changed, so ``is`` tells a monitor
        whether to look closer.
        """
        return self.status.last

    def feedback_message(self, path: str) -> str:
        """The current ``feedback_message`` of the node at ``path`` ("" if none or unknown)."""
        return self.status.feedback_message(path)

    @property
    def tick_writes(self) -> list[tuple[str, Any]]:
        """Blackboard writes of the last tick, ``[(key, value)]`` (kept while logging)."""
        return self.blackboard.writes

    @property
    def overruns(self) -> int:
        """Ticks that started late (past their period, or behind the asked speed)."""
        return self.pacer.overruns

    @property
    def record_requested(self) -> bool:
        """True when the caller named a record directory (``--record DIR``), so plugins
        record videos there; the default ``runs/`` directory gets only the log."""
        return self._record not in (None, True, False)

    # ------------------------------------------------------------------
    # The run
    # ------------------------------------------------------------------

    def execute(self) -> RunResult:
        """Run the tree to its end and return how it ended; the rig is stopped and closed."""
        if self._executed:
            raise RuntimeError("a Run executes once; make a new one")
        self._executed = True
        wall0 = time.monotonic()
        bt = self._bt = py_trees.trees.BehaviourTree(self.root)
        result: RunResult | None = None
        stop_key = self._key = StopKey() if self._stop_key else None
        try:
            with (
                self.interrupts.signals(self._handle_signals) as owns_signals,
                stop_key if stop_key is not None else contextlib.nullcontext(),
            ):
                # A plugin may refuse the run here (a ConfigError: exit 2, nothing built).
                self.hooks.call("armtree_run_opening", run=self)
                self._open_log()
                self.blackboard.start(getattr(self.tree, "blackboard", None), self.log.enabled)
                try:
                    profile: ProfileView | None = getattr(self.tree, "profile", None)
                    if self.rig is None and profile is not None:
                        self.rig = build_rig(
                            profile,
                            self._manager(),
                            self.clock,
                            seed=self.seed,
                            interrupt=self.interrupt,
                            record_dir=self.record_dir,
                        )
                    self._setup(bt)
                    self._index_nodes()
                    self.hooks.notify("armtree_run_started", run=self)
                    self.view.start(self)
                    self.watchdog.start(rig=self.rig, log=self.log, owns_process=owns_signals)
                    try:
                        end = self._loop(stop_key)
                    finally:
                        self.watchdog.close()
                except End as exc:
                    end = exc
                except HardwareFault as exc:
                    end = End("FAILURE", f"hardware fault: {exc}", EXIT_HARDWARE)
                    self.report.traceback = tb_module.format_exc()
                except TickAbandoned:
                    self.watchdog.close()
                    end = self._interrupted()
                result = self._finish(end, bt, wall0)
        finally:
            self.watchdog.stopped.set()
            self._cleanup()
        result.record_errors = list(self.record_errors)
        return result

    def _manager(self) -> PluginManager:
        if self.manager is None:
            self.manager = plugin_manager(self.tree)
        return self.manager

    def _open_log(self) -> None:
        self.record_dir = choose_record_dir(self._record, self.tree.name, self._runs_dir)
        if self.record_dir is None:
            return
        self.log = open_log(
            self.record_dir, self.tree, seed=self.seed, tick_hz=self.tick_hz, clock=self.clock
        )
        self.feedback = FeedbackLog(self.log)
        self.report.log = self.log

    def _setup(self, bt: py_trees.trees.BehaviourTree) -> None:
        # An update() that returns no status ends the run at that tick (not a spin).
        guard_statuses(bt.root)
        runtime: BehaviourRuntime = self  # mypy checks the Run offers what behaviours ask
        try:
            bt.setup(rig=self.rig, clock=self.clock, runtime=runtime)
        except Exception as exc:  # noqa: BLE001 - reported with the node it came from
            raise self.report.behaviour_exception(self.tick_count, exc, "setup") from exc

    def _index_nodes(self) -> None:
        self.status.reset(self.root)
        self.feedback.reset(self.status.nodes, self.status.paths)
        self.stall.start(self.clock.now(), self.status.nodes, getattr(self.rig, "arm", None))

    def _loop(self, stop_key: StopKey | None) -> End:
        clock, root, rig = self.clock, self.root, self.rig
        watchdog = self.watchdog.watch
        assert watchdog is not None
        interrupts, report, pacer, pause = self.interrupts, self.report, self.pacer, self.pause
        timeout, max_ticks = self.timeout, self.max_ticks
        tick_hooks = self.hooks.has("armtree_tick")
        logging = self.log.enabled
        next_poll = time.monotonic()
        next_flush = next_poll + _FLUSH_S
        pacer.start()
        while True:
            if interrupts.requested:
                return self._interrupted()
            if report.fail_reason is not None:
                return report.component_failed(self.tick_count)
            if timeout is not None and clock.now() >= timeout - 1e-9:
                return self._timed_out(timeout)
            if max_ticks is not None and self.tick_count >= max_ticks:
                return End("FAILURE", f"max ticks: {max_ticks} ticks reached")
            if pause.due(rig):
                pause.hold(
                    tick=self.tick_count,
                    log=self.log,
                    keys=stop_key,
                    announce=self._paused,
                    show=lambda: self.view.update(self, ()),
                )
                if interrupts.requested:
                    return self._interrupted()
            if self.replacement.due():
                self.replacement.swap()
                root = self.root
            self.tick_count += 1
            tick_start = time.monotonic()
            now = self.tick_time = clock.now()
            pacer.began(now)
            watchdog.begin("a component step")
            if rig is not None:
                try:
                    rig.step(now)
                except Exception as exc:  # noqa: BLE001 - a component failed between ticks
                    return report.component_exception(self.tick_count, exc)
                if report.fail_reason is not None:
                    return report.component_failed(self.tick_count)
            watchdog.phase = "the tree's tick"
            try:
                for _ in root.tick():
                    pass
            except Exception as exc:  # noqa: BLE001 - reported with the node it came from
                return report.behaviour_exception(self.tick_count, exc, "tick")
            watchdog.end()
            self._track(now, logging)
            if self.stall.observe(now, self.status.last, bool(self.blackboard.writes)):
                self._stalled(now)
            if tick_hooks:
                self.hooks.notify("armtree_tick", run=self)
            wall = time.monotonic()
            self.tick_wall = wall - tick_start
            if wall >= next_poll:
                next_poll = wall + POLL_S
                if stop_key is not None:
                    pause.read_keys(stop_key)
                if wall >= next_flush:
                    # A run killed outright (SIGKILL, power) keeps all but the last second.
                    next_flush = wall + _FLUSH_S
                    self.log.flush()
            status = root.status
            if status == Status.SUCCESS:
                return End("SUCCESS", "", EXIT_SUCCESS)
            if status == Status.FAILURE:
                if interrupts.fault is not None:
                    # A device fault (a lost link) failed the tree: the fault is the cause.
                    return self._interrupted()
                return report.tree_failed(rig)
            pacer.advance(self.tick_count, self.control.speed)

    def _stalled(self, now: float) -> None:
        running = self.index.running_leaves()
        quiet = now - self.stall.quiet_since
        where = f" while {', '.join(running)} ran" if running else ""
        message = (
            f"stall: no progress for {quiet:g} s (no status change, motion, blackboard write "
            f"or feedback change){where}"
        )
        if not self._view_changes:  # --quiet shows nothing else: a spinning run must not be silent
            print(f"warning: t={now:.2f}s {message}", file=sys.stderr, flush=True)
        self.report.event(
            self.tick_count,
            "stall",
            message,
            seconds=round(quiet, 3),
            since=round(self.stall.quiet_since, 3),
            running=running,
        )

    def _timed_out(self, timeout: float) -> End:
        message = f"timeout: {timeout:g} s on the run clock reached"
        if self.stall.stalled:
            message += f"; no progress since t={self.stall.quiet_since:.2f} s (a stall)"
        return End("FAILURE", message)

    def _paused(self, paused: bool) -> None:
        if paused:
            self.view.message(f"paused after tick {self.tick_count}: p resume, n step, q stop")
        self.hooks.notify("armtree_run_paused", run=self, paused=paused)

    def _track(self, now: float, logging: bool) -> None:
        changes = self.status.track(now, logging, self._view_changes)
        # Every tick, so a live view can show time passing; views throttle themselves.
        self.view.update(self, changes)
        if logging:
            self.blackboard.record(self.log, self.tick_count, now)

    def _interrupted(self) -> End:
        reason = self.report.note_interrupt(self.tick_count, self.watchdog.stuck())
        self.hooks.notify("armtree_interrupt", run=self, reason=reason)
        return self.report.interrupted(self.tick_count)

    # ------------------------------------------------------------------
    # Replacing the tree (--watch)
    # ------------------------------------------------------------------

    def replace_tree(self, tree: Tree) -> None:
        """Run ``tree`` (validated, built with this run's profile) instead of the current one.

        Safe from any thread: the swap happens between ticks at the next safe
        point (:class:`armtree.runtime.tree_replacement.TreeReplacement`). The old tree is
        halted cleanly first; the rig, the clock, the log and the blackboard carry
        on. A later call replaces a tree still waiting. ``armtree_tree_replaced``
        is called after the swap.
        """
        self.replacement.offer(tree)

    @property
    def replacement_waiting(self) -> str | None:
        """Why a tree given to :meth:`replace_tree` still waits (``None`` when none waits)."""
        return self.replacement.waiting

    def install_tree(self, tree: Tree) -> None:
        """Make ``tree`` the one ticked: the previous one shut down, ``tree`` set up and
        its nodes indexed for the log and views (for :class:`TreeReplacement`)."""
        with contextlib.suppress(Exception):
            if self._bt is not None:
                self._bt.shutdown()
        self.tree, self.root = tree, tree.root
        self.index.use(tree)
        self._bt = py_trees.trees.BehaviourTree(self.root)
        self._setup(self._bt)
        self._index_nodes()

    def note_statuses(self, now: float) -> None:
        """Log and show the status changes since the last tick (after a halt between ticks)."""
        self._track(now, self.log.enabled)

    # ------------------------------------------------------------------
    # Stopping
    # ------------------------------------------------------------------

    def _halt_owner(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        behaviour.stop(Status.INVALID)
        self.status.note_stopped(behaviour)

    def final_statuses(self) -> dict[Any, tuple[str, bool]]:
        """``{node.id: (status name, halted)}``: each node's last status other than INVALID.

        py_trees leaves halted nodes INVALID, which hides how a run ended; this
        keeps, for every node, the last SUCCESS, FAILURE or RUNNING it had in
        this run (``"INVALID"`` if it never ran) and whether it was then halted
        from RUNNING. Kept only while the run's view takes updates (not quiet).
        """
        return self.status.final()

    def halt_tree(self) -> list[str]:
        """Stop every RUNNING node with INVALID (calling its terminate); return errors raised
        (:meth:`armtree.runtime.halting.Halter.halt`)."""
        return self.halter.halt()

    def _finish(self, end: End, bt: py_trees.trees.BehaviourTree, wall0: float) -> RunResult:
        self.interrupts.stopping = True
        self._end_status = end.status
        halted = self.ending.halt(end.status, self.rig)
        if self.status.nodes:
            self._track(self.clock.now(), self.log.enabled)
        with contextlib.suppress(Exception):
            (self._bt or bt).shutdown()
        reason = self.interrupts.reason
        result = self.ending.result(end, halted, self.log, self.tick_count, wall0, reason)
        truth = functools.partial(self.hooks.notify, "armtree_ground_truth", run=self)
        self.ending.judge(result, self.tree, self.manager, truth)
        self.view.stop(self)
        self.hooks.notify("armtree_run_finished", run=self, result=result)
        self.ending.write(result, self.log)
        return result

    def _cleanup(self) -> None:
        self.interrupts.stopping = True
        log_error = self.ending.close(
            ended=bool(self._end_status),
            rig=self.rig,
            close_rig=self._own_rig if self._close_rig is None else self._close_rig,
            log=self.log,
            closers=self.closers,
        )
        if log_error is not None:
            self.record_errors.append(log_error)

    def _force_exit(self) -> None:
        self.watchdog.force_exit(key=self._key, view=self.view, log=self.log, rig=self.rig)


def run(
    tree: Tree,
    rig: Rig | None = None,
    seed: int = 0,
    realtime: bool = False,
    record: Path | str | bool | None = None,
    timeout: float | None = None,
    max_ticks: int | None = None,
    quiet: bool = True,
    manager: PluginManager | None = None,
    **options: Any,
) -> RunResult:
    """Run a loaded :class:`~armtree.loader.tree.Tree` to its end and return a :class:`RunResult`.

    ``rig``: a built rig to use (default: built from ``tree.profile``, and
    closed at the end); ``seed``: for the simulation; ``realtime``: tick on
    the wall clock (also chosen when the profile names real hardware);
    ``record``: the run-log directory (default ``runs/<tree>-<time>/``,
    ``False`` for no log); ``timeout`` (seconds on the run clock) and
    ``max_ticks`` end the run as FAILURE; ``quiet=False`` shows the live view;
    ``manager``: the plugin manager for the rig and the lifecycle hooks.
    Further ``options`` go to :class:`Run` (``stop_timeout``, ``runs_dir``,
    ``handle_signals``, ``stop_key``, ``view``, ``close_rig``, ``debug``).
    """
    return Run(
        tree,
        rig,
        seed=seed,
        realtime=realtime,
        record=record,
        timeout=timeout,
        max_ticks=max_ticks,
        quiet=quiet,
        manager=manager,
        **options,
    ).execute()


__all__ = ["Run", "run"]
