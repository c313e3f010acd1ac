"""What a run shows in the terminal: a live tree, plain status lines, or nothing; and the summary.

* :class:`LiveView`: a rich Live rendering of the tree with each node's status
  and feedback message (``self.feedback_message``), redrawn at most ``max_hz`` times per wall-clock second however fast the
  virtual clock ticks;
* :class:`PlainView`: one line per status change (with the node's feedback
  message), for logs and pipes;
* :class:`NullView`: ``--quiet``.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Mapping, Sequence
from typing import Any, Protocol, TextIO

import py_trees
from py_trees.common import Status
from rich.console import Console
from rich.live import Live
from rich.text import Text
from rich.tree import Tree as RichTree

from armtree.api.clock import Clock
from armtree.loader.tree import Tree

from .run_end import RunResult


class Run(Protocol):
    """What a view reads of the run it shows (:class:`armtree.runtime.runner.Run`, which
    hands itself to its view)."""

    @property
    def clock(self) -> Clock: ...
    @property
    def tree(self) -> Tree: ...
    @property
    def tick_hz(self) -> float: ...
    @property
    def tick_count(self) -> int: ...
    @property
    def overruns(self) -> int: ...


#: (symbol, rich style) of each status.
STYLES: dict[Status, tuple[str, str]] = {
    Status.SUCCESS: ("✓", "green"),
    Status.FAILURE: ("✗", "red"),
    Status.RUNNING: ("*", "yellow"),
    Status.INVALID: ("-", "dim"),
}

#: A status change: (node path, old status name, new status name).
Change = tuple[str, str, str]

#: Each node's final status for the last frame: ``{node.id: (status name, halted)}``.
FinalStatuses = Mapping[Any, tuple[str, bool]]


class NullView:
    """Shows nothing (``--quiet``)."""

    def start(self, run: Run) -> None:
        """Called once before the first tick."""

    def update(self, run: Run, changes: Sequence[Change]) -> None:
        """Called after every tick with the status changes it made (possibly none)."""

    def message(self, text: str) -> None:
        """An event worth telling the user (interrupt, preemption, hook error)."""

    def stop(self, run: Run) -> None:
        """Called once after the tree has been halted."""

    def abort(self) -> None:
        """The process is being forced out: release the terminal at once."""


class PlainView(NullView):
    """One line per status change, for a stdout that is not a terminal."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self.stream = stream if stream is not None else sys.stdout

    def start(self, run: Run) -> None:
        """Print the tree's name and clock."""
        kind = "virtual" if run.clock.virtual else "wall"
        self._print(f"run {run.tree.name}: {run.tick_hz:g} Hz on the {kind} clock")

    def update(self, run: Run, changes: Sequence[Change]) -> None:
        """Print each change with the tick, the run time and the node's feedback message."""
        if not changes:
            return
        head = f"tick {run.tick_count} t={run.clock.now():.3f}s"
        feedback = getattr(run, "feedback_message", None)
        lines = []
        for path, old, new in changes:
            message = feedback(path) if feedback is not None and new != "INVALID" else ""
            tail = f"  ({message})" if message else ""
            lines.append(f"{head} {path}: {old} -> {new}{tail}")
        self._print("\n".join(lines))

    def message(self, text: str) -> None:
        """Print an event line."""
        self._print(text)

    def _print(self, text: str) -> None:
        self.stream.write(text + "\n")
        self.stream.flush()


class LiveView(NullView):
    """The tree with statuses, redrawn in place at most ``max_hz`` times per second."""

    def __init__(self, console: Console | None = None, max_hz: float = 10.0) -> None:
        self.console = console or Console()
        self.min_interval = 1.0 / max_hz
        self._live: Live | None = None
        self._last = 0.0
        self._messages: list[str] = []

    def start(self, run: Run) -> None:
        """Start the live display."""
        self._live = Live(
            self._render(run), console=self.console, auto_refresh=False, transient=False
        )
        self._live.start(refresh=True)
        self._last = time.monotonic()

    def update(self, run: Run, changes: Sequence[Change]) -> None:
        """Redraw if the last redraw is older than the refresh interval."""
        now = time.monotonic()
        if self._live is not None and now - self._last >= self.min_interval:
            self._last = now
            self._live.update(self._render(run), refresh=True)

    def message(self, text: str) -> None:
        """Keep the last few events under the tree."""
        self._messages = (self._messages + [text])[-5:]

    def stop(self, run: Run) -> None:
        """Draw the final state and stop the live display.

        The final frame shows each node's last status of the run, marked
        ``halted`` where the halt stopped it RUNNING, not the INVALID py_trees
        leaves behind (py_trees issue #132).
        """
        if self._live is not None:
            final = getattr(run, "final_statuses", None)
            self._live.update(self._render(run, final() if final else None), refresh=True)
            self._live.stop()
            self._live = None

    def abort(self) -> None:
        """Stop the live display without a final redraw (forced exit)."""
        if self._live is not None:
            self._live.stop()
            self._live = None

    def _render(self, run: Run, statuses: FinalStatuses | None = None) -> Any:
        header = Text(
            f"{run.tree.name}  tick {run.tick_count}  t={run.clock.now():.2f}s"
            f"  overruns {run.overruns}",
            style="bold",
        )
        control = getattr(run, "control", None)
        state = control.state if control is not None else "running"
        if state != "running":
            header.append(f"  {state.upper()}", style="bold magenta")
        header.append("   (p pause/resume, n step, q or Ctrl-C stop)", style="dim")
        tree = render_tree(run.tree.root, header, statuses)
        if self._messages:
            from rich.console import Group

            return Group(tree, *(Text(m, style="magenta") for m in self._messages))
        return tree


def render_tree(
    root: py_trees.behaviour.Behaviour,
    label: Any = None,
    statuses: FinalStatuses | None = None,
) -> RichTree:
    """A rich tree of ``root`` with each node's status symbol, name, type and feedback message.

    ``statuses`` (``{node.id: (status name, halted)}``, as from
    :meth:`armtree.runtime.runner.Run.final_statuses`) stands in for INVALID, for
    the final frame after a halt; a halted node is marked ``halted``. Nodes
    with any other current status, or missing from it, show their current status.
    """
    top = RichTree(label if label is not None else _label(root, statuses))
    stack: list[tuple[py_trees.behaviour.Behaviour, RichTree]] = []
    if label is not None:
        stack.append((root, top.add(_label(root, statuses))))
    else:
        stack.append((root, top))
    while stack:
        node, branch = stack.pop()
        for child in node.children:
            stack.append((child, branch.add(_label(child, statuses))))
    return top


def _label(node: py_trees.behaviour.Behaviour, statuses: FinalStatuses | None = None) -> Text:
    status, halted = node.status, False
    if status == Status.INVALID and statuses is not None and node.id in statuses:
        name, halted = statuses[node.id]
        status = Status(name)
    symbol, style = STYLES.get(status, ("?", ""))
    text = Text(f"{symbol} ", style=style)
    text.append(node.name, style=style if status != Status.INVALID else "")
    text.append(f"  [{type(node).__name__}]", style="dim")
    if halted:
        text.append("  halted", style="magenta")
    message = getattr(node, "feedback_message", "")
    if message:
        text.append(f"  {_one_line(str(message))}", style="italic")
    return text


def _one_line(message: str, limit: int = 120) -> str:
    """A feedback message as one line of at most ``limit`` characters, for the tree view."""
    line = " ".join(message.split())
    return line if len(line) <= limit else line[: limit - 1] + "…"


def make_view(quiet: bool, stream: TextIO | None = None) -> NullView:
    """The view for a run: none when quiet, live on a terminal, plain lines otherwise."""
    stream = stream if stream is not None else sys.stdout
    if quiet:
        return NullView()
    if stream.isatty():
        return LiveView(Console(file=stream))
    return PlainView(stream)


#: Marks of an expectation's status in the summary.
EXPECT_MARKS = {"pass": "✓", "fail": "✗", "not checked": "?"}
#: Most absorbed failures and events listed in the summary (the log has them all).
SUMMARY_ITEMS = 5


def summary(result: RunResult) -> str:
    """The end-of-run summary: result, ticks, virtual and wall time, overruns, why it failed.

    A false success (SUCCESS while the world disagrees) gets its own line,
    starting ``FALSE SUCCESS``, right after the result; a false failure one
    starting ``false failure``. Then the chain of failures from the root to
    the leaf, failures a retry or selector absorbed, the events components
    reported (collisions, drops, missed steps, faults), one ``expect:`` line
    per declared outcome with what was measured, and one ``label: text`` line
    per entry of ``result.details``, in order (what plugins added in
    ``armtree_run_finished``, e.g. the simulation's score).
    """
    from armtree.api.outcomes.failures import chain_text

    verdict = getattr(result, "verdict", "")
    lines = [f"result: {result.status}  (exit {result.exit_code})"]
    if verdict == "false success":
        lines.append(f"FALSE SUCCESS: {result.message.split(': ', 1)[-1]}")
    elif verdict == "false failure":
        lines.append("false failure: the tree ended FAILURE but every expectation holds")
    lines.append(
        f"ticks: {result.ticks}  run time: {result.seconds:.3f} s  wall time: "
        f"{result.wall_seconds:.3f} s  overruns: {result.overruns}"
    )
    if result.failed_node:
        lines.append(f"failed: {result.failed_node}")
    if result.message and verdict != "false success":
        lines.append(f"why: {result.message}")
    chain = getattr(result, "chain", None) or []
    if chain:
        lines.append(f"chain: {chain_text(chain)}")
    absorbed = getattr(result, "absorbed", None) or []
    for failure in absorbed[-SUMMARY_ITEMS:]:
        lines.append(f"absorbed: t={failure[0].t:.2f}s {chain_text(failure)}")
    if len(absorbed) > SUMMARY_ITEMS:
        lines.append(f"absorbed: ... and {len(absorbed) - SUMMARY_ITEMS} earlier")
    events = getattr(result, "events", None) or []
    for event in events[:SUMMARY_ITEMS]:
        lines.append(f"event: t={event['t']:.2f}s {event['message']}")
    if len(events) > SUMMARY_ITEMS:
        lines.append(f"event: ... and {len(events) - SUMMARY_ITEMS} more (in the log)")
    for r in getattr(result, "expectations", None) or []:
        mark = EXPECT_MARKS.get(r.status, "?")
        status = "not checked: " if r.status == "not checked" else ""
        lines.append(f"expect: {mark} {r.expect} ({status}{r.detail})")
    if result.log_path is not None:
        lines.append(f"log: {result.log_path}")
    for label, text in (getattr(result, "details", None) or {}).items():
        lines.append(f"{label}: {text}")
    return "\n".join(lines)


def print_summary(result: RunResult, stream: TextIO | None = None) -> None:
    """Print :func:`summary`, coloured on a terminal."""
    stream = stream if stream is not None else sys.stdout
    style = {"SUCCESS": "green", "FAILURE": "red"}.get(result.status, "magenta")
    console = Console(file=stream, highlight=False)
    text = summary(result)
    first, _, rest = text.partition("\n")
    # soft_wrap: paths and messages stay on one line, so they can be copied and grepped.
    console.print(Text(first, style=f"bold {style}"), soft_wrap=True)
    for line in rest.splitlines():
        if line.startswith("FALSE SUCCESS"):
            line_style = "bold white on red"
        elif line.startswith(("false failure", "expect: ✗", "event: ")):
            line_style = "yellow"
        else:
            line_style = ""
        console.print(Text(line, style=line_style), soft_wrap=True)
