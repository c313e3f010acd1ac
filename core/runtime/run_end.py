"""How a run ends, on every path: the tree halted and left safe, the arm stopped after an
abnormal end, the :class:`RunResult` built, judged against the world and written as the
log's last record, and everything the run opened closed."""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from armtree.api.clock import Clock
from armtree.api.outcomes.expect import judge, predicates_for, verdict
from armtree.api.outcomes.failures import FailureLog
from armtree.api.rig import Rig
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.tree import Tree

from .blackboard_log import BlackboardLog
from .failure_report import EXIT_FAILURE, EXIT_SUCCESS, End, FailureReport
from .halting import Halter
from .node_index import NodeIndex
from .pacing import Pacer
from .resources import Resources
from .runlog import RunLog


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
    :class:`armtree.api.outcomes.expect.ExpectationResult` per entry of the tree's
    ``expect:``; ``verdict`` is ``success``, ``failure``, ``false success``
    (SUCCESS while an expectation failed: exit code 1), ``false failure``
    (FAILURE while every expectation held) or ``interrupted``. ``chain`` is
    the failure from the root down to the leaf that failed
    (:class:`armtree.api.outcomes.failures.NodeFailure` each, with its reason), ``absorbed``
    the failures a retry or selector swallowed (as chains), ``events`` the
    notable events components reported (collisions, drops, missed steps,
    faults), each ``{"tick", "t", "event", "message", ...}``. ``record_errors``
    names the files of the run's record that could not be written (a full disk),
    each ``"name: reason"``: the record is incomplete and the CLI says so (exit 2).
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
    record_errors: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True for SUCCESS."""
        return self.status == "SUCCESS"

    @property
    def false_success(self) -> bool:
        """True when the tree said SUCCESS and an expectation failed."""
        return self.verdict == "false success"


@dataclass
class Halted:
    """What halting a run's tree left: the leaves that were running (paths), the errors
    a terminate raised, the nodes still not safe after the stop timeout."""

    running: list[str]
    errors: list[str]
    unsafe: list[str]


@dataclass(kw_only=True, eq=False)
class RunEnding:
    """Ends one run: :meth:`halt`, then :meth:`result` and :meth:`write`; :meth:`close`
    on every path, also after an unexpected exception.

    It halts through ``halter``, reads what failed from ``report``, ``index`` and
    ``failures``, the tick timing from ``pacer``, and at the close releases
    ``resources`` and turns off the ``blackboard`` log.
    """

    halter: Halter
    report: FailureReport
    index: NodeIndex
    pacer: Pacer
    resources: Resources
    blackboard: BlackboardLog
    clock: Clock
    failures: FailureLog
    stop_timeout: float
    # The tick-start lateness of the result, for its record.
    _lateness: dict[str, float] = field(default_factory=dict, init=False)

    def halt(self, status: str, rig: Rig | None) -> Halted:
        """Stop every RUNNING node, the arm too unless the run succeeded, and step the
        rig while behaviours are still halting (up to the stop timeout)."""
        running = self.report.running
        if running is None:
            running = self.index.running_leaves() if status != "SUCCESS" else []
        errors = self.halter.halt()
        if status != "SUCCESS" and rig is not None:
            rig.stop()
        unsafe = self.halter.settle()
        return Halted(running, errors, unsafe)

    def result(
        self, end: End, halted: Halted, log: RunLog, ticks: int, wall0: float, reason: Any
    ) -> RunResult:
        """The result of a run that ended with ``end`` and was ``halted``; the halt's
        errors and a stop timeout are logged at ``ticks``. ``wall0``: when the run began
        (``time.monotonic``); ``reason``: the interrupt's."""
        now = self.clock.now
        message = end.message
        for err in halted.errors:
            log.event(ticks, now(), "halt_error", error=err)
        if halted.unsafe:
            message += ("; " if message else "") + (
                f"not safe after the {self.stop_timeout:g} s stop timeout: "
                f"{', '.join(halted.unsafe)}"
            )
            log.event(ticks, now(), "stop_timeout", nodes=halted.unsafe)
        result = RunResult(
            status=end.status,
            ticks=ticks,
            seconds=now(),
            wall_seconds=time.monotonic() - wall0,
            overruns=self.pacer.overruns,
            log_path=log.path,
            message=message,
            failed_node=self.report.failed_node,
            exit_code=end.exit_code,
            running=halted.running,
            reason=reason,
            traceback=self.report.traceback,
        )
        lateness = self._lateness = lateness_ms(self.pacer.lateness)
        if lateness:
            result.details["tick start"] = (
                f"{lateness['p50']:.2f} ms late (p50), {lateness['p99']:.2f} ms (p99), "
                f"{lateness['max']:.1f} ms (max) after schedule; {result.overruns} overruns"
            )
        return result

    def judge(
        self,
        result: RunResult,
        tree: Tree,
        manager: PluginManager | None,
        ground_truth: Callable[[], Any],
    ) -> None:
        """Judge ``result`` against ``tree``'s ``expect:`` (:func:`judge_result`), with the
        predicates of ``manager``'s plugins and the world ``ground_truth()`` gives."""
        judge_result(
            result,
            expect=list(getattr(tree, "expect", None) or ()),
            ground_truth=ground_truth,
            manager=manager,
            failures=self.failures,
            root_path=self.index.path_of(tree.root),
            events=self.report.events,
        )

    def write(self, result: RunResult, log: RunLog) -> None:
        """Write the ``result`` record, the log's last, and flush the log."""
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
        if self._lateness:
            record["tick_lateness_ms"] = self._lateness
        log.write(record)
        log.flush()

    def close(
        self, *, ended: bool, rig: Rig | None, close_rig: bool, log: RunLog, closers: list[Any]
    ) -> str | None:
        """Release and close what the run holds and opened, newest closer first; a run
        that did not end (an unexpected exception) is halted and its arm stopped first.
        Returns why the run log could not be written to its end (a full disk), if so."""
        if not ended:
            # Left by an unexpected exception (or KeyboardInterrupt without our
            # handlers): nothing may stay RUNNING, whatever went wrong.
            with contextlib.suppress(Exception):
                self.halter.halt()
            if rig is not None:
                rig.stop()
        self.blackboard.stop(log.enabled)
        self.resources.release_all()
        if rig is not None and close_rig:
            rig.close()
        while closers:
            closer = closers.pop()
            try:
                closer()
            except Exception as exc:  # noqa: BLE001 - closing goes on past a broken closer
                print(
                    f"warning: closing {closer!r} raised {type(exc).__name__}: {exc}",
                    file=sys.stderr,
                )
        try:
            log.close()
        except OSError as exc:
            return f"{log.path.name if log.path else 'run.jsonl'}: {exc.strerror or exc}"
        return None


def judge_result(
    result: RunResult,
    *,
    expect: Sequence[Any],
    ground_truth: Callable[[], Any],
    manager: PluginManager | None,
    failures: FailureLog,
    root_path: str,
    events: Sequence[dict[str, Any]],
) -> None:
    """Judge the tree's ``expect:`` on the world's ground truth (asked for only when
    there is something to judge); note the chain of failures and the events.

    A false success keeps its status (what the tree said) but exits 1, with the
    failed expectations in its message.
    """
    result.chain = failures.chain(root_path) if result.status == "FAILURE" else []
    result.absorbed = failures.absorbed(root_path)
    result.events = list(events)
    world = ground_truth() if expect else None
    try:
        predicates = predicates_for(manager.registry if manager is not None else None)
    except Exception:  # noqa: BLE001 - a clash was reported when the tree loaded
        predicates = {}
    result.expectations = judge(list(expect), world, predicates)
    result.verdict = verdict(result.status, result.expectations)
    if result.verdict == "false success":
        failed = "; ".join(f"{r.expect} ({r.detail})" for r in result.expectations if r.failed)
        result.exit_code = EXIT_FAILURE
        result.message = f"false success: the tree ended SUCCESS but the world disagrees: {failed}"


def lateness_ms(lateness: Sequence[float]) -> dict[str, float]:
    """p50, p99 and max (ms) of tick-start lateness in seconds; empty for no ticks."""
    if not lateness:
        return {}
    ms = sorted(1000.0 * max(0.0, x) for x in lateness)

    def pct(q: float) -> float:
        return ms[min(len(ms) - 1, int(q * (len(ms) - 1) + 0.5))]

    return {"p50": pct(0.50), "p99": pct(0.99), "max": ms[-1], "ticks": float(len(ms))}
