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
   between ticks it holds while ``run.control`` (:mod:`armtree.control`) asks it
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
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
import traceback as tb_module
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import py_trees
from py_trees.blackboard import ActivityType, Blackboard
from py_trees.common import Status

from .clock import Clock, VirtualClock, WallClock
from .control import RunControl
from .display import NullView, make_view
from .errors import HardwareFault
from .feedback_log import FeedbackLog
from .halting import Halter
from .interrupts import EXIT_INTERRUPTED, Interrupts, StopKey
from .outcomes import FailureLog, judge, predicates_for, verdict
from .resources import Resources
from .rig import Rig
from .rig_builder import build_rig, uses_real_hardware
from .run_hooks import RunHooks
from .runlog import RunLog, default_run_dir, jsonable
from .status_tracking import StatusTracker
from .tree_replacement import TreeReplacement
from .watchdog import (
    DEFAULT_TICK_S,
    TickAbandoned,
    TickWatchdog,
    force_exit_later,
    innermost_code,
    running_behaviour,
)

EXIT_SUCCESS = 0
EXIT_FAILURE = 1
EXIT_HARDWARE = 3

#: Blackboard activities written to the run log.
_LOGGED_ACTIVITIES = frozenset(
    {ActivityType.WRITE.value, ActivityType.INITIALISED.value, ActivityType.UNSET.value}
)
#: How often the stop key is polled, in wall seconds.
_POLL_S = 0.05
#: How often the run log is flushed during a run, in wall seconds.
_FLUSH_S = 1.0
#: py_trees' name of the FAILURE status (the status tuples hold these strings).
_FAILURE = Status.FAILURE._value_
#: Events reported by components (``Run.report_event``) kept for the summary.
_EVENTS_KEPT = 200


@dataclass
class RunResult:
    """How a run ended.

    ``status`` is ``"SUCCESS"``, ``"FAILURE"`` or ``"INTERRUPTED"``; ``ticks``
    the number of ticks; ``seconds`` the time on the run's clock (virtual in
    simulation) and ``wall_seconds`` the real time it took; ``overruns`` the
    ticks that started late on a wall clock; ``message`` says why it ended
    when it was not a plain success; ``failed_node`` is the path of the node
    that raised, or of the deepest failing node; ``running`` the leaves that
    were RUNNING when the run was halted; ``exit_code`` follows the CLI's
    convention (0, 1, 3 hardware fault, 130 interrupted). ``details`` are
    extra ``label: text`` lines for the end-of-run summary, filled by plugins
    in ``armtree_run_finished`` (e.g. the simulation's score); they are not
    written to the run log.

    How the world saw it: ``expectations`` holds one
    :class:`armtree.outcomes.ExpectationResult` per entry of the tree's
    ``expect:``; ``verdict`` is ``success``, ``failure``, ``false success``
    (SUCCESS while an expectation failed: exit code 1), ``false failure``
    (FAILURE while every expectation held) or ``interrupted``. ``chain`` is
    the failure from the root down to the leaf that failed
    (:class:`armtree.outcomes.NodeFailure` each, with its reason), ``absorbed``
    the failures a retry or selector swallowed (as chains), ``events`` the
    notable events components reported (collisions, drops, missed steps,
    faults), each ``{"tick", "t", "event", "message", ...}``.
    """

    status: str
    ticks: int
    seconds: float
    wall_seconds: float = 0.0
    overruns: int = 0
    log_path: Path | None = None
    message: str = ""
    failed_node: str | None = None
    exit_code: int = EXIT_SUCCESS
    running: list[str] = field(default_factory=list)
    reason: str | None = None
    traceback: str | None = None
    details: dict[str, str] = field(default_factory=dict)
    expectations: list[Any] = field(default_factory=list)
    verdict: str = ""
    chain: list[Any] = field(default_factory=list)
    absorbed: list[list[Any]] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True for SUCCESS."""
        return self.status == "SUCCESS"

    @property
    def false_success(self) -> bool:
        """True when the tree said SUCCESS and an expectation failed."""
        return self.verdict == "false success"


class _End(Exception):
    """Internal: the tick loop is over for the given status and message."""

    def __init__(self, status: str, message: str = "", exit_code: int = EXIT_FAILURE) -> None:
        super().__init__(message)
        self.status = status
        self.message = message
        self.exit_code = exit_code


class Run:
    """One run of a tree: clock, rig, log, resources, interrupts and the tick loop.

    Construct it and call :meth:`execute` once (or use :func:`run`). Behaviours
    reach it as ``self.runtime``; hooks receive it as ``run``.
    ``close_rig`` defaults to closing only a rig this run built itself.
    """

    def __init__(
        self,
        tree: Any,
        rig: Rig | None = None,
        *,
        seed: int = 0,
        realtime: bool = False,
        record: Path | str | bool | None = None,
        timeout: float | None = None,
        max_ticks: int | None = None,
        quiet: bool = True,
        manager: Any = None,
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
        if rig is not None:
            self.clock: Clock = rig.clock
        elif realtime or (
            profile is not None
            and uses_real_hardware(profile, self.manager.registry if self.manager else None)
        ):
            self.clock = WallClock()
        else:
            self.clock = VirtualClock()
        self.tick_count = 0
        self.overruns = 0
        #: On a wall clock, how late each tick started against its schedule (seconds).
        self.tick_lateness: list[float] = []
        self.interrupts = Interrupts(force_exit=self._force_exit)
        #: Pause, step, resume, stop and speed, from any thread (page, keys, tests).
        self.control = RunControl(self.interrupts)
        #: The command-line options that started the run (``{}`` from the API), read by
        #: plugins that added options of their own (``armtree_run_options``).
        self.settings: dict[str, Any] = dict(settings or {})
        #: Called with no argument when the run is over, whatever happened, newest first:
        #: for what a plugin opened in ``armtree_run_opening`` (a server, a watcher).
        self.closers: list[Any] = []
        #: What plugins keep for this run, each under a key of its own (``"monitor"``).
        self.plugin_state: dict[str, Any] = {}
        #: Blackboard writes of the last tick, ``[(key, value)]`` (kept while logging).
        self.tick_writes: list[tuple[str, Any]] = []
        #: Wall seconds the last tick took: rig step, tree tick, logging, tick hooks.
        self.tick_wall = 0.0
        #: Run time at which the last tick started (the ``t`` of its log records).
        self.tick_time = 0.0
        self._anchor: tuple[float, float, float] | None = None
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
        self._owns_process = False
        self._stop_key = stop_key
        self._record = record
        self._runs_dir = Path(runs_dir)
        self.log = RunLog(None)
        self.record_dir: Path | None = None
        #: Every node's status from tick to tick: logged, noted when failing, shown.
        self.status = StatusTracker(self)
        #: Writes the run log's feedback records (replaced with the log in _open_log).
        self.feedback = FeedbackLog(self.log)
        self.hooks = RunHooks(self)
        self._executed = False
        self._end_status = ""
        # Filled in as the run ends: what failed, where, and what was running.
        self._end_traceback: str | None = None
        self._failed_node: str | None = None
        self._running: list[str] | None = None
        self._key: StopKey | None = None
        self.tick_limit = tick_limit if tick_limit is not None else _profile_tick_limit(profile)
        self._watchdog: TickWatchdog | None = None
        self._watchdog_closed = False
        self._stopped = threading.Event()
        self.failures = FailureLog()
        #: Notable events components reported, for the summary (the log has them all).
        self.events: list[dict[str, Any]] = []
        self._fail_reason: str | None = None

    # ------------------------------------------------------------------
    # For behaviours and components
    # ------------------------------------------------------------------

    def claim(self, behaviour: py_trees.behaviour.Behaviour, names: Any) -> None:
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
        if self._fail_reason is None:
            self._fail_reason = reason
            self.interrupts.wake.set()

    def report_event(self, event: str, message: str | None = None, **data: Any) -> None:
        """Write a component's event to the run log at the current tick.

        With a ``message`` (a collision, a drop, a missed step, a fault) it is
        also shown in the live view and listed in the summary. ``data`` are the
        record's fields (JSON-safe values). Call it from the run's thread (a
        stepper or a behaviour).
        """
        t = self.clock.now()
        self.log.event(self.tick_count, t, event, **data)
        if message:
            self.view.message(f"t={t:.2f}s {message}")
            if len(self.events) < _EVENTS_KEPT:
                self.events.append(
                    {"tick": self.tick_count, "t": t, "event": event, "message": message}
                )

    def path_of(self, behaviour: py_trees.behaviour.Behaviour) -> str:
        """The node's path in the tree (``"Root/Branch/Leaf"``), from the loader's NodeInfo if any."""
        info = self._info(behaviour)
        if info is not None and getattr(info, "path", None):
            return info.path
        names = []
        node: Any = behaviour
        while node is not None:
            names.append(node.name)
            node = node.parent
        return "/".join(reversed(names))

    def where(self, behaviour: py_trees.behaviour.Behaviour) -> str:
        """``"path (file:line)"`` of a node, as far as it is known."""
        info = self._info(behaviour)
        mark = getattr(info, "mark", None) if info is not None else None
        path = self.path_of(behaviour)
        return f"{path} ({mark.file}:{mark.line})" if mark is not None else path

    def _info(self, behaviour: py_trees.behaviour.Behaviour) -> Any:
        nodes = getattr(self.tree, "nodes", None)
        return nodes.get(behaviour.id) if nodes else None

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
                self._owns_process = owns_signals
                # A plugin may refuse the run here (a ConfigError: exit 2, nothing built).
                self.hooks.call("armtree_run_opening", run=self)
                self._open_log()
                self._prepare_blackboard()
                try:
                    if self.rig is None and getattr(self.tree, "profile", None) is not None:
                        self.rig = build_rig(
                            self.tree.profile,
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
                    self._start_watchdog(owns_signals)
                    try:
                        end = self._loop(stop_key)
                    finally:
                        self._close_watchdog()
                except _End as exc:
                    end = exc
                except HardwareFault as exc:
                    end = _End("FAILURE", f"hardware fault: {exc}", EXIT_HARDWARE)
                    self._end_traceback = tb_module.format_exc()
                except TickAbandoned:
                    self._close_watchdog()
                    end = self._interrupted()
                result = self._finish(end, bt, wall0)
        finally:
            self._stopped.set()
            self._cleanup()
        return result

    def _manager(self) -> Any:
        if self.manager is None:
            self.manager = getattr(getattr(self.tree, "profile", None), "manager", None)
        if self.manager is None:
            from . import plugin_manager

            factory = getattr(
                plugin_manager, "get_plugin_manager", plugin_manager.make_plugin_manager
            )
            self.manager = factory(getattr(self.tree, "plugins", ()) or ())
        return self.manager

    @property
    def record_requested(self) -> bool:
        """True when the caller named a record directory (``--record DIR``), so plugins
        record videos there; the default ``runs/`` directory gets only the log."""
        return self._record not in (None, True, False)

    def _open_log(self) -> None:
        if self._record is False:
            return
        if self._record in (None, True):
            self.record_dir = default_run_dir(self.tree.name, self._runs_dir)
        else:
            self.record_dir = Path(self._record)
        self.log = RunLog(self.record_dir / "run.jsonl")
        self.feedback = FeedbackLog(self.log)
        self.log.write(
            {
                "kind": "start",
                "tick": 0,
                "t": 0.0,
                "tree": self.tree.name,
                "source": str(getattr(self.tree, "source", "") or ""),
                "seed": self.seed,
                "tick_hz": self.tick_hz,
                "clock": "virtual" if self.clock.virtual else "wall",
                "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                "blackboard": dict(getattr(self.tree, "blackboard", None) or {}),
            }
        )

    def _prepare_blackboard(self) -> None:
        # py_trees' blackboard is process-wide: a run starts from the tree's own values
        # only. Clients and key registrations made at load time are kept.
        Blackboard.storage.clear()
        for key, value in (getattr(self.tree, "blackboard", None) or {}).items():
            Blackboard.set(key if key.startswith("/") else "/" + key, value)
        if self.log.enabled:
            Blackboard.enable_activity_stream(maximum_size=100_000)

    def _setup(self, bt: py_trees.trees.BehaviourTree) -> None:
        try:
            bt.setup(rig=self.rig, clock=self.clock, runtime=self)
        except Exception as exc:  # noqa: BLE001 - reported with the node it came from
            raise self._behaviour_exception(exc, "setup") from exc

    def _index_nodes(self) -> None:
        self.status.reset(self.root)
        self.feedback.reset(self.status.nodes, self.status.paths)

    def _loop(self, stop_key: StopKey | None) -> _End:
        clock, root, rig = self.clock, self.root, self.rig
        watchdog = self._watchdog
        assert watchdog is not None
        virtual = clock.virtual
        interrupts = self.interrupts
        period = self.period
        timeout, max_ticks = self.timeout, self.max_ticks
        tick_hooks = self.hooks.has("armtree_tick")
        logging = self.log.enabled
        control = self.control
        next_poll = time.monotonic()
        next_flush = next_poll + _FLUSH_S
        t0 = next_t = clock.now()
        while True:
            if interrupts.requested:
                return self._interrupted()
            if self._fail_reason is not None:
                return self._component_failed()
            if timeout is not None and clock.now() >= timeout - 1e-9:
                return _End("FAILURE", f"timeout: {timeout:g} s on the run clock reached")
            if max_ticks is not None and self.tick_count >= max_ticks:
                return _End("FAILURE", f"max ticks: {max_ticks} ticks reached")
            if control.holding and self._at_safe_point():
                self._hold(stop_key)
                if interrupts.requested:
                    return self._interrupted()
            if self.replacement.due():
                self.replacement.swap()
                root = self.root
            self.tick_count += 1
            tick_start = time.monotonic()
            now = self.tick_time = clock.now()
            if not virtual:
                self.tick_lateness.append(now - next_t)
            watchdog.begin("a component step")
            if rig is not None:
                try:
                    rig.step(now)
                except Exception as exc:  # noqa: BLE001 - a component failed between ticks
                    return self._component_exception(exc)
                if self._fail_reason is not None:
                    return self._component_failed()
            watchdog.phase = "the tree's tick"
            try:
                for _ in root.tick():
                    pass
            except Exception as exc:  # noqa: BLE001 - reported with the node it came from
                return self._behaviour_exception(exc, "tick")
            watchdog.end()
            self._track(now, logging)
            if tick_hooks:
                self.hooks.notify("armtree_tick", run=self)
            wall = time.monotonic()
            self.tick_wall = wall - tick_start
            if wall >= next_poll:
                next_poll = wall + _POLL_S
                if stop_key is not None:
                    self._keys(stop_key)
                if wall >= next_flush:
                    # A run killed outright (SIGKILL, power) keeps all but the last second.
                    next_flush = wall + _FLUSH_S
                    self.log.flush()
            status = root.status
            if status == Status.SUCCESS:
                return _End("SUCCESS", "", EXIT_SUCCESS)
            if status == Status.FAILURE:
                if interrupts.fault is not None:
                    # A device fault (a lost link) failed the tree: the fault is the cause.
                    return self._interrupted()
                fault = self._component_fault()
                if fault is not None:
                    return _End("FAILURE", f"hardware fault: {fault}", EXIT_HARDWARE)
                return _End("FAILURE", self._failure_message())
            # Tick k starts at k periods; multiplying (not summing) keeps times exact-ish,
            # and rounding to a nanosecond keeps logs free of float noise.
            next_t = round(t0 + self.tick_count * period, 9) if virtual else next_t + period
            if virtual:
                clock.sleep_until(next_t)
                if control.speed is not None:
                    self._pace(next_t, control.speed)
            else:
                late = clock.now() - next_t
                if late > 0:
                    # The tick took longer than its period: count it and start the next
                    # one now rather than bunching ticks to catch up.
                    self.overruns += 1
                    next_t = clock.now()
                else:
                    interrupts.wake.wait(-late)

    def _keys(self, keys: StopKey) -> None:
        typed = keys.read()
        if typed:
            self.control.key(typed)

    def _at_safe_point(self) -> bool:
        """A tick boundary where holding leaves the arm stopped: on a virtual clock
        always (nothing the runtime steps moves while it stands), otherwise once the
        arm has no command under way."""
        arm = getattr(self.rig, "arm", None)
        return self.clock.virtual or arm is None or not arm.busy()

    def replace_tree(self, tree: Any) -> None:
        """Run ``tree`` (validated, built with this run's profile) instead of the current one.

        Safe from any thread: the swap happens between ticks at the next safe
        point (:class:`armtree.tree_replacement.TreeReplacement`). The old tree is
        halted cleanly first; the rig, the clock, the log and the blackboard carry
        on. A later call replaces a tree still waiting. ``armtree_tree_replaced``
        is called after the swap.
        """
        self.replacement.offer(tree)

    @property
    def replacement_waiting(self) -> str | None:
        """Why a tree given to :meth:`replace_tree` still waits (``None`` when none waits)."""
        return self.replacement.waiting

    def install_tree(self, tree: Any) -> None:
        """Make ``tree`` the one ticked: the previous one shut down, ``tree`` set up and
        its nodes indexed for the log and views (for :class:`TreeReplacement`)."""
        with contextlib.suppress(Exception):
            if self._bt is not None:
                self._bt.shutdown()
        self.tree, self.root = tree, tree.root
        self._bt = py_trees.trees.BehaviourTree(self.root)
        self._setup(self._bt)
        self._index_nodes()

    def note_statuses(self, now: float) -> None:
        """Log and show the status changes since the last tick (after a halt between ticks)."""
        self._track(now, self.log.enabled)

    def _hold(self, keys: StopKey | None) -> None:
        """Stand still (clock held, nothing halted) until resumed, stepped or stopped."""
        control, clock, wake = self.control, self.clock, self.control.wake
        clock.hold()
        control.enter()
        self.log.event(self.tick_count, clock.now(), "paused")
        self.log.flush()
        self.view.message(f"paused after tick {self.tick_count}: p resume, n step, q stop")
        self.hooks.notify("armtree_run_paused", run=self, paused=True)
        while control.must_wait() and not self.interrupts.requested:
            wake.wait(_POLL_S)
            wake.clear()
            if keys is not None:
                self._keys(keys)
            self.view.update(self, ())
        stepping = control.leave()
        clock.release()
        self._anchor = None
        if not self.interrupts.requested:
            self.log.event(self.tick_count, clock.now(), "step" if stepping else "resumed")
            self.hooks.notify("armtree_run_paused", run=self, paused=False)

    def _pace(self, t: float, speed: float) -> None:
        """On a virtual clock, wait until run time ``t`` is due at ``speed`` run s per wall s."""
        wall = time.monotonic()
        anchor = self._anchor
        if anchor is None or anchor[2] != speed:
            self._anchor = (wall, t, speed)
            return
        delay = anchor[0] + (t - anchor[1]) / speed - wall
        if delay > 0:
            self.interrupts.wake.wait(delay)
        else:
            # Behind: count it, and start again from now rather than bunching ticks.
            self.overruns += 1
            self._anchor = (wall, t, speed)

    def _track(self, now: float, logging: bool) -> None:
        changes = self.status.track(now, logging, self._view_changes)
        # Every tick, so a live view can show time passing; views throttle themselves.
        self.view.update(self, changes)
        if logging:
            stream = Blackboard.activity_stream
            if self.tick_writes:
                self.tick_writes = []
            if stream is not None and stream.data:
                self._log_blackboard(stream.data, now)
                stream.clear()

    def feedback_message(self, path: str) -> str:
        """The current ``feedback_message`` of the node at ``path`` ("" if none or unknown)."""
        return self.status.feedback_message(path)

    def _log_blackboard(self, items: list[Any], now: float) -> None:
        writes = self.tick_writes
        for item in items:
            if item.activity_type in _LOGGED_ACTIVITIES:
                writes.append((item.key, item.current_value))
                self.log.write(
                    {
                        "kind": "blackboard",
                        "tick": self.tick_count,
                        "t": now,
                        "key": item.key,
                        "op": item.activity_type,
                        "client": item.client_name,
                        "value": jsonable(item.current_value),
                    }
                )

    def _component_fault(self) -> HardwareFault | None:
        """A fault a rig component holds (a lost link, a camera that stopped), if any."""
        for part in ("arm", "camera"):
            fault = getattr(getattr(self.rig, part, None), "fault", None)
            if isinstance(fault, HardwareFault):
                return fault
        return None

    def _failure_message(self) -> str:
        failed = self._deepest(Status.FAILURE)
        self._failed_node = self.path_of(failed) if failed is not None else None
        if failed is None:
            return "FAILURE"
        why = (getattr(failed, "feedback_message", "") or "").strip()
        return f"the tree failed at {self.where(failed)}" + (f": {why}" if why else "")

    def _deepest(self, status: Status) -> py_trees.behaviour.Behaviour | None:
        node = self.root
        if node.status != status:
            return None
        while node.children:
            nxt = next((c for c in reversed(node.children) if c.status == status), None)
            if nxt is None:
                break
            node = nxt
        return node

    def _running_leaves(self) -> list[str]:
        return [
            self.path_of(n)
            for n in self.root.iterate()
            if n.status == Status.RUNNING and not n.children
        ]

    def _interrupted(self) -> _End:
        reason = self.interrupts.reason or "interrupt"
        fault = self.interrupts.fault
        self._running = self._running_leaves()
        watchdog = self._watchdog
        if watchdog is not None and watchdog.fired and watchdog.stuck_in:
            # The node whose tick never returned is not RUNNING yet, but it is what ran.
            stuck = f"{watchdog.stuck_in} (a tick that did not return)"
            self._running = [stuck, *self._running]
        self.log.event(
            self.tick_count, self.clock.now(), "interrupt", reason=reason, running=self._running
        )
        self.view.message(f"interrupted: {reason}")
        if fault is not None:
            self.report_event("fault", f"fault: {fault}", error=str(fault))
        self.hooks.notify("armtree_interrupt", run=self, reason=reason)
        where = ", ".join(self._running) if self._running else "no running behaviour"
        message = f"interrupted by {reason} at tick {self.tick_count} (t={self.clock.now():.3f} s) in {where}"
        if fault is not None:
            return _End("INTERRUPTED", f"{message}: hardware fault: {fault}", EXIT_HARDWARE)
        return _End("INTERRUPTED", message, EXIT_INTERRUPTED)

    def _behaviour_exception(self, exc: BaseException, phase: str) -> _End:
        node = _raising_behaviour(exc)
        self._end_traceback = "".join(tb_module.format_exception(exc))
        where = self.where(node) if node is not None else "the tree"
        self._failed_node = self.path_of(node) if node is not None else None
        self.halter.raiser = node
        message = f"{type(exc).__name__} in {phase} of {where}: {exc}"
        self.log.event(
            self.tick_count,
            self.clock.now(),
            "exception",
            node=self._failed_node,
            phase=phase,
            error=f"{type(exc).__name__}: {exc}",
            traceback=self._end_traceback,
        )
        code = EXIT_HARDWARE if isinstance(exc, HardwareFault) else EXIT_FAILURE
        return _End("FAILURE", message, code)

    def _component_failed(self) -> _End:
        reason = self._fail_reason or "a component failed"
        self._running = self._running_leaves()
        where = f" while {', '.join(self._running)} ran" if self._running else ""
        self.log.event(
            self.tick_count, self.clock.now(), "fail", reason=reason, running=self._running
        )
        return _End("FAILURE", f"{reason}{where}")

    def _component_exception(self, exc: Exception) -> _End:
        self._end_traceback = "".join(tb_module.format_exception(exc))
        self.log.event(
            self.tick_count,
            self.clock.now(),
            "component_error",
            error=f"{type(exc).__name__}: {exc}",
            traceback=self._end_traceback,
        )
        if isinstance(exc, HardwareFault):
            self.report_event("fault", f"fault: {exc}", error=str(exc))
            return _End("FAILURE", f"hardware fault: {exc}", EXIT_HARDWARE)
        return _End("FAILURE", f"{type(exc).__name__} in a component step: {exc}")

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
        (:meth:`armtree.halting.Halter.halt`)."""
        return self.halter.halt()

    def _finish(self, end: _End, bt: py_trees.trees.BehaviourTree, wall0: float) -> RunResult:
        self.interrupts.stopping = True
        self._end_status = end.status
        running = self._running
        if running is None:
            running = self._running_leaves() if end.status != "SUCCESS" else []
        errors = self.halter.halt()
        if end.status != "SUCCESS" and self.rig is not None:
            self.rig.stop()
        unsafe = self.halter.settle()
        if self.status.nodes:
            self._track(self.clock.now(), self.log.enabled)
        with contextlib.suppress(Exception):
            (self._bt or bt).shutdown()
        message = end.message
        for err in errors:
            self.log.event(self.tick_count, self.clock.now(), "halt_error", error=err)
        if unsafe:
            message += ("; " if message else "") + (
                f"not safe after the {self.stop_timeout:g} s stop timeout: {', '.join(unsafe)}"
            )
            self.log.event(self.tick_count, self.clock.now(), "stop_timeout", nodes=unsafe)
        result = RunResult(
            status=end.status,
            ticks=self.tick_count,
            seconds=self.clock.now(),
            wall_seconds=time.monotonic() - wall0,
            overruns=self.overruns,
            log_path=self.log.path,
            message=message,
            failed_node=self._failed_node,
            exit_code=end.exit_code,
            running=running,
            reason=self.interrupts.reason,
            traceback=self._end_traceback,
        )
        lateness = lateness_ms(self.tick_lateness)
        if lateness:
            result.details["tick start"] = (
                f"{lateness['p50']:.2f} ms late (p50), {lateness['p99']:.2f} ms (p99), "
                f"{lateness['max']:.1f} ms (max) after schedule; {result.overruns} overruns"
            )
        self._judge(result)
        self.view.stop(self)
        self.hooks.notify("armtree_run_finished", run=self, result=result)
        record = {
            "kind": "result",
            "tick": result.ticks,
            "t": result.seconds,
            "status": result.status,
            "ticks": result.ticks,
            "seconds": result.seconds,
            "wall_seconds": result.wall_seconds,
            "overruns": result.overruns,
            "message": result.message,
            "failed_node": result.failed_node,
            "exit_code": result.exit_code,
            "running": result.running,
            "verdict": result.verdict,
            "expectations": [r.to_dict() for r in result.expectations],
            "chain": [f.to_dict() for f in result.chain],
            "absorbed": [[f.to_dict() for f in c] for c in result.absorbed],
            "events": result.events,
        }
        if lateness:
            record["tick_lateness_ms"] = lateness
        self.log.write(record)
        self.log.flush()
        return result

    def _judge(self, result: RunResult) -> None:
        """Judge the tree's ``expect:`` on the ground truth; note the chain of failures.

        A false success keeps its status (what the tree said) but exits 1, with
        the failed expectations in its message.
        """
        root_path = self.path_of(self.root)
        result.chain = self.failures.chain(root_path) if result.status == "FAILURE" else []
        result.absorbed = self.failures.absorbed(root_path)
        result.events = list(self.events)
        expect = list(getattr(self.tree, "expect", None) or ())
        world = None
        if expect:
            world = self.hooks.notify("armtree_ground_truth", run=self)
        try:
            predicates = predicates_for(self.manager)
        except Exception:  # noqa: BLE001 - a clash was reported when the tree loaded
            predicates = {}
        result.expectations = judge(expect, world, predicates)
        result.verdict = verdict(result.status, result.expectations)
        if result.verdict == "false success":
            failed = "; ".join(f"{r.expect} ({r.detail})" for r in result.expectations if r.failed)
            result.exit_code = EXIT_FAILURE
            result.message = (
                f"false success: the tree ended SUCCESS but the world disagrees: {failed}"
            )

    def _cleanup(self) -> None:
        self.interrupts.stopping = True
        if not self._end_status:
            # Left by an unexpected exception (or KeyboardInterrupt without our
            # handlers): nothing may stay RUNNING, whatever went wrong.
            with contextlib.suppress(Exception):
                self.halt_tree()
            if self.rig is not None:
                self.rig.stop()
        if Blackboard.activity_stream is not None and self.log.enabled:
            Blackboard.disable_activity_stream()
        self.resources.release_all()
        close = self._own_rig if self._close_rig is None else self._close_rig
        if self.rig is not None and close:
            self.rig.close()
        while self.closers:
            closer = self.closers.pop()
            try:
                closer()
            except Exception as exc:  # noqa: BLE001 - closing goes on past a broken closer
                print(
                    f"warning: closing {closer!r} raised {type(exc).__name__}: {exc}",
                    file=sys.stderr,
                )
        self.log.close()

    # ------------------------------------------------------------------
    # The tick watchdog
    # ------------------------------------------------------------------

    def _start_watchdog(self, owns_signals: bool) -> None:
        self._watchdog = TickWatchdog(
            self.tick_limit,
            pending=lambda: self.interrupts.reason,
            on_overrun=self._on_overrun,
            stop_arm=self._request_arm_stop,
            describe=self._describe_stuck,
            use_signal=owns_signals,
        )
        self.interrupts.watchdog = self._watchdog
        self._watchdog.start()

    def _close_watchdog(self) -> None:
        watchdog = self._watchdog
        if watchdog is None or self._watchdog_closed:
            return
        self._watchdog_closed = True
        stuck_in = watchdog.phase if watchdog.tick_started is not None else ""
        watchdog.close()
        if watchdog.fired:
            self.halter.rig_stuck = stuck_in == "a component step"
            if self._owns_process:
                # The stop may be stuck as well (a terminate that never returns): the
                # process ends with the cause's code after the stop's own time.
                code = EXIT_HARDWARE if self.interrupts.fault is not None else EXIT_INTERRUPTED
                force_exit_later(self.stop_timeout + 3.0, code, self._last_words, self._stopped)

    def _on_overrun(self, message: str) -> None:
        self.interrupts.request("tick watchdog", HardwareFault(message, "tick watchdog"))

    def _request_arm_stop(self) -> None:
        rig = self.rig
        if rig is None:
            return
        request = getattr(rig, "request_stop", None)
        if callable(request):
            request()
        else:
            threading.Thread(target=rig.stop, name="arm stop", daemon=True).start()

    def _describe_stuck(self, frame: Any) -> str:
        node = running_behaviour(frame, lambda o: isinstance(o, py_trees.behaviour.Behaviour))
        if node is not None:
            # Halted like a node that raised: it may have started something.
            self.halter.raiser = node
            self._failed_node = self.path_of(node)
            return self.where(node)
        return innermost_code(frame)

    def _last_words(self) -> None:
        self.log.event(self.tick_count, self.clock.now(), "forced_exit")
        self.log.close()

    def _force_exit(self) -> None:
        # Leave the terminal usable: echo back on, cursor shown.
        if self._key is not None:
            self._key.restore()
        with contextlib.suppress(Exception):
            self.view.abort()
        with contextlib.suppress(Exception):
            self.log.event(self.tick_count, self.clock.now(), "forced_exit")
            self.log.close()
        with contextlib.suppress(Exception):
            if self.rig is not None:
                self.rig.stop()
        from .interrupts import _exit_now

        _exit_now()


def _profile_tick_limit(profile: Any) -> float:
    """The profile's ``watchdog: {tick_s: S}``, else the default (wall seconds)."""
    data = getattr(profile, "data", None)
    section = data.get("watchdog") if isinstance(data, dict) else None
    if isinstance(section, dict) and isinstance(section.get("tick_s"), (int, float)):
        return float(section["tick_s"])
    return DEFAULT_TICK_S


def lateness_ms(lateness: Sequence[float]) -> dict[str, float]:
    """p50, p99 and max (ms) of tick-start lateness in seconds; empty for no ticks."""
    if not lateness:
        return {}
    ms = sorted(1000.0 * max(0.0, x) for x in lateness)

    def pct(q: float) -> float:
        return ms[min(len(ms) - 1, int(q * (len(ms) - 1) + 0.5))]

    return {"p50": pct(0.50), "p99": pct(0.99), "max": ms[-1], "ticks": float(len(ms))}


def _raising_behaviour(exc: BaseException) -> py_trees.behaviour.Behaviour | None:
    """The deepest py_trees behaviour whose method is on the exception's traceback."""
    found = None
    tb = exc.__traceback__
    while tb is not None:
        candidate = tb.tb_frame.f_locals.get("self")
        if isinstance(candidate, py_trees.behaviour.Behaviour):
            found = candidate
        tb = tb.tb_next
    return found


def run(
    tree: Any,
    rig: Rig | None = None,
    seed: int = 0,
    realtime: bool = False,
    record: Path | str | bool | None = None,
    timeout: float | None = None,
    max_ticks: int | None = None,
    quiet: bool = True,
    manager: Any = None,
    **options: Any,
) -> RunResult:
    """Run a loaded :class:`~armtree.tree.Tree` to its end and return a :class:`RunResult`.

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


__all__ = ["Run", "RunResult", "run"]
