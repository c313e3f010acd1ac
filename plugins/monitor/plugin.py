"""The monitor's hooks: ``--monitor``, ``--monitor-host``, ``--watch``, ``run.mcap``, ``armtree replay``."""

from __future__ import annotations

import argparse
import sys
from typing import Any

import armtree
from armtree.runtime.runner import Run

from .ports import port_number
from .session import KEY, MonitorSession
from .watch import TreeWatcher

#: The page's port when ``--monitor`` is given without one.
DEFAULT_PORT = 8765


@armtree.hookimpl
def armtree_run_options(parser: argparse.ArgumentParser) -> None:
    """``--monitor [PORT]``, ``--monitor-host HOST`` and ``--watch``."""
    group = parser.add_argument_group("monitor")
    group.add_argument(
        "--monitor",
        nargs="?",
        const=DEFAULT_PORT,
        type=port_number,
        metavar="PORT",
        help=f"serve the live monitor page on http://127.0.0.1:PORT/ (default {DEFAULT_PORT}; "
        "0 for any free port); a simulated run then keeps to real time",
    )
    group.add_argument(
        "--monitor-host",
        metavar="HOST",
        help="serve the monitor on HOST instead of 127.0.0.1 (0.0.0.0: every interface); "
        "the page then needs the token printed at start",
    )
    group.add_argument(
        "--watch",
        action="store_true",
        help="when the tree file changes, validate it and swap it in at a safe point "
        "(an invalid change is reported and the running tree goes on)",
    )


@armtree.hookimpl
def armtree_run_opening(run: Run) -> None:
    """Start the monitor's server before anything is built (a busy port is exit 2)."""
    settings = run.settings
    port, host = settings.get("monitor"), settings.get("monitor_host")
    if port is None and host is None:
        return
    from .live import LiveFeed  # its web server loads only when a run asks for the monitor

    feed = LiveFeed(run, host or "127.0.0.1", DEFAULT_PORT if port is None else port)
    url = feed.start()
    session = MonitorSession.of(run)
    session.feeds.append(feed)
    if run.clock.virtual and run.control.speed is None:
        run.control.speed = 1.0
    note = " (the token is required: keep this URL to yourself)" if feed.server.token else ""
    print(f"monitor: {url}{note}", flush=True)
    print("keys: p pause/resume, n step, r resume, q stop", file=sys.stderr, flush=True)


@armtree.hookimpl
def armtree_run_started(run: Run) -> None:
    """Attach the session: the tree record, the recording, the page's feed, the watcher."""
    session = MonitorSession.of(run)
    session.start()
    if run.settings.get("watch"):
        session.watcher = TreeWatcher(run, report=session.on_watch)
        session.watcher.start()
        if session.watcher.source is None:
            print("watch: this tree has no file to watch", file=sys.stderr, flush=True)
        else:
            names = ", ".join(str(p) for p in session.watcher.files)
            print(f"watch: watching {names}", file=sys.stderr, flush=True)


@armtree.hookimpl
def armtree_tree_replaced(run: Run, previous: Any) -> None:
    """Describe the new tree to the log, the recording and the page."""
    session = run.plugin_state.get(KEY)
    if session is None:
        return
    session.reindexed()
    if session.watcher is not None:
        text = f"swapped in the changed tree at tick {run.tick_count}"
        print(f"watch: {text}", file=sys.stderr, flush=True)
        session.on_watch("loaded", text, [])


@armtree.hookimpl
def armtree_tick(run: Run) -> None:
    """Sample the tick for the recording and the page."""
    session = run.plugin_state.get(KEY)
    if session is not None:
        session.tick()


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """``armtree replay RUN_DIR``."""
    from .replay import ReplayCommand

    return {"replay": ReplayCommand}
