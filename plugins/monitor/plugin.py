"""The monitor's hooks: ``--monitor``, ``--monitor-host``, ``--watch``, ``run.mcap``, ``armtree replay``."""

from __future__ import annotations

from typing import Any

import armtree

from .session import MonitorSession


@armtree.hookimpl
def armtree_run_started(run: Any) -> None:
    """Attach the session: the tree record, the recording, the page's feed."""
    MonitorSession.of(run).start()


@armtree.hookimpl
def armtree_tick(run: Any) -> None:
    """Sample the tick for the recording and the page."""
    session = run.plugin_state.get("monitor")
    if session is not None:
        session.tick()
