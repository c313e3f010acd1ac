"""What the monitor keeps for one run: observer, taps, scene sampler, recording, page feed."""

from __future__ import annotations

import json
import time
from typing import Any

from armtree.runtime.runner import Run

from .observer import RunObserver
from .recording import McapRecorder
from .scene import SceneSampler
from .taps import RigTaps

#: Key of the session in ``run.plugin_state``.
KEY = "monitor"


class MonitorSession:
    """Ties one run to its recording and its live page.

    Built in ``armtree_run_opening`` (when the page is asked for) or
    ``armtree_run_started``; :meth:`start` attaches to the started run,
    :meth:`tick` is called after every tick, :meth:`close` when the run is over.
    ``feeds`` are objects with ``on_tick(session, sample)``, ``on_record(session,
    record)``, ``on_state(session, state)`` and ``on_tree(session)`` (the page's server).
    """

    def __init__(self, run: Run) -> None:
        self.run = run
        self.feeds: list[Any] = []
        self.observer: RunObserver | None = None
        self.taps: RigTaps | None = None
        self.scene: SceneSampler | None = None
        self.recorder: McapRecorder | None = None
        self.result: dict[str, Any] | None = None
        self.watcher: Any = None
        self._closed = False

    @classmethod
    def of(cls, run: Run) -> MonitorSession:
        """The run's session, made on first use."""
        session = run.plugin_state.get(KEY)
        if session is None:
            session = run.plugin_state[KEY] = cls(run)
            run.closers.append(session.close)
        return session

    @property
    def active(self) -> bool:
        """True when something looks: a page or a recording."""
        return bool(self.feeds) or self.recorder is not None

    def start(self) -> None:
        """Attach to a run that has built its rig and set its tree up."""
        run = self.run
        self.observer = RunObserver(run)
        run.log.write(tree_record(self.observer.tree, 0, 0.0))
        if run.record_requested and run.record_dir is not None:
            start_ns = time.time_ns() - round(run.clock.now() * 1e9)
            self.recorder = McapRecorder(
                run.record_dir / "run.mcap",
                start_ns,
                {"tree": run.tree.name, "seed": run.seed, "tick_hz": run.tick_hz},
            )
            self.recorder.add_tree(self.observer.tree, 0.0)
            start = _first_record(run)
            if start is not None:
                self.recorder.add_record(start)
        if self.active:
            rig = getattr(run, "rig", None)
            if rig is not None:
                self.taps = RigTaps(rig)
            self.scene = SceneSampler(run, self.taps)
            run.log.listeners.append(self.on_record)
            run.control.listeners.append(self.on_state)
        for feed in self.feeds:
            feed.on_tree(self)

    def tick(self) -> None:
        """After a tick: sample it and hand it on."""
        if self.watcher is not None:
            for event in self.watcher.take_events():
                name = event.pop("event")
                self.run.log.event(self.run.tick_count, self.run.clock.now(), name, **event)
        observer = self.observer
        if observer is None or not self.active:
            return
        sample = observer.sample()
        recorder = self.recorder
        if recorder is not None:
            recorder.add_tick(sample, observer.blackboard)
            recorder.add_stats(sample.tick, sample.t, observer.rate.summary(), sample.overruns)
            taps = self.taps
            seen = taps.shown() if taps is not None else None
            # wants_image is False for None too; the test is written out for mypy
            if seen is not None and recorder.wants_image(sample.t, seen):
                recorder.add_image(seen, sample.tick, sample.t)
            if self.scene is not None and recorder.wants_scene(sample.t):
                recorder.add_scene(self.scene.sample(), sample.t)
        for feed in self.feeds:
            feed.on_tick(self, sample)

    def reindexed(self) -> None:
        """The run swapped in a new tree (``--watch``)."""
        if self.observer is None:
            return
        self.observer.reindex()
        self.run.log.write(
            tree_record(self.observer.tree, self.run.tick_count, self.run.clock.now())
        )
        if self.recorder is not None:
            self.recorder.add_tree(self.observer.tree, self.run.clock.now())
        for feed in self.feeds:
            feed.on_tree(self)

    def on_record(self, record: dict[str, Any]) -> None:
        """A run-log record (event, result...) as it is written."""
        kind = record.get("kind")
        if kind not in ("event", "result"):
            return
        if kind == "result":
            self.result = record
        if self.recorder is not None:
            self.recorder.add_record(record)
        for feed in self.feeds:
            feed.on_record(self, record)

    def on_watch(self, kind: str, text: str, errors: list[str]) -> None:
        """What the tree watcher found: ``invalid``, ``waiting`` or ``loaded``."""
        for feed in self.feeds:
            feed.on_watch(self, kind, text, errors)

    def on_state(self, state: str) -> None:
        """The run's control changed state (running, pausing, paused)."""
        for feed in self.feeds:
            feed.on_state(self, state)

    def close(self) -> None:
        """Finish the recording, take the taps off, let the feeds know (idempotent)."""
        if self._closed:
            return
        self._closed = True
        if self.watcher is not None:
            self.watcher.stop()
        if self.taps is not None:
            self.taps.remove()
        if self.recorder is not None:
            self.recorder.close()
            error = self.recorder.error
            errors = getattr(self.run, "record_errors", None)
            if error is not None and errors is not None:
                reason = getattr(error, "strerror", None) or str(error)
                errors.append(f"{self.recorder.path.name}: {reason}")
        for feed in self.feeds:
            feed.on_close(self)


def tree_record(tree: dict[str, Any], tick: int, t: float) -> dict[str, Any]:
    """The run log's ``tree`` record: the tree's description at the top level (the log keeps
    JSON only a few levels deep)."""
    return {"kind": "tree", "tick": tick, "t": t, **tree}


def tree_of(record: dict[str, Any]) -> dict[str, Any]:
    """The tree description in a ``tree`` record."""
    return {k: v for k, v in record.items() if k not in ("kind", "tick", "t")}


def _first_record(run: Run) -> dict[str, Any] | None:
    """The run log's start record, read back (it was written before any listener)."""
    path = getattr(run.log, "path", None)
    if path is None:
        return None
    run.log.flush()
    try:
        with path.open(encoding="utf-8") as fh:
            return json.loads(fh.readline())
    except (OSError, ValueError):
        return None


__all__ = ["KEY", "MonitorSession", "tree_of", "tree_record"]
