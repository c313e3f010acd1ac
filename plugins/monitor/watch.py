"""``--watch``: when the tree file (or a file it includes) changes, validate it and swap it in.

A thread polls the files' modification times. A change is loaded with the
run's own options (profile, ``--set`` overrides, plugins) and validated as
``run-tree`` would; a tree that fails is reported in the terminal and on the
page, and the running tree goes on. One that loads is handed to
:meth:`armtree.runtime.runner.Run.replace_tree`, which swaps it in at the next safe
point (no motion under way, nothing held unless the new tree starts by
handling it).
"""

from __future__ import annotations

import sys
import threading
from pathlib import Path
from typing import Any

from armtree.errors import ConfigError
from armtree.loader.tree import Tree
from armtree.runtime.runner import Run

#: Seconds between looks at the files, and the quiet time a change needs before loading
#: (editors write a file in several steps).
POLL_S = 0.25
SETTLE_S = 0.3


def watched_files(tree: Tree) -> list[Path]:
    """The tree's file and every file its nodes were read from (included subtrees)."""
    files = []
    source = getattr(tree, "source", None)
    if source:
        files.append(Path(source))
    for info in (getattr(tree, "nodes", None) or {}).values():
        mark = getattr(info, "mark", None)
        if mark is not None and mark.file:
            files.append(Path(mark.file))
    return list(dict.fromkeys(p for p in files if p.is_file()))


def _stamp(path: Path) -> tuple[int, int] | None:
    try:
        stat = path.stat()
    except OSError:
        return None
    return stat.st_mtime_ns, stat.st_size


class TreeWatcher:
    """Watches a run's tree files and hands validated changes to the run.

    ``report(kind, text, errors)`` is called from the watcher's thread with
    ``"invalid"`` (``errors``: ``FILE:LINE:COL: message`` lines), ``"waiting"``
    (a validated tree waits for a safe point) or ``"loaded"``.
    """

    def __init__(self, run: Run, report: Any = None) -> None:
        self.run = run
        self.report = report
        source = getattr(run.tree, "source", None)
        self.source = Path(source) if source else None
        self.files = watched_files(run.tree)
        self._stamps = {p: _stamp(p) for p in self.files}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="armtree-watch", daemon=True)
        #: What the run log should get from this thread, taken by the run's thread.
        self.pending_events: list[dict[str, Any]] = []
        self._lock = threading.Lock()

    def start(self) -> None:
        """Start polling."""
        if self.source is not None:
            self._thread.start()

    def stop(self) -> None:
        """Stop polling (idempotent)."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(2.0)

    def take_events(self) -> list[dict[str, Any]]:
        """Events for the run log (called on the run's thread)."""
        with self._lock:
            events, self.pending_events = self.pending_events, []
        return events

    def _changed(self) -> bool:
        return any(_stamp(p) != s for p, s in self._stamps.items())

    def _watch(self) -> None:
        while not self._stop.wait(POLL_S):
            if not self._changed():
                continue
            # Let the editor finish writing: wait until the files stay the same a while.
            stamps = None
            while stamps != (stamps := {p: _stamp(p) for p in self.files}):
                if self._stop.wait(SETTLE_S):
                    return
            self._stamps = stamps
            self._load()

    def _load(self) -> None:
        from armtree.loader.tree_loader import load_tree

        source = self.source
        if source is None:  # never: start() polls only a tree read from a file
            return
        settings = self.run.settings
        try:
            tree = load_tree(
                source,
                rig=settings.get("rig"),
                overrides=settings.get("overrides") or (),
                manager=self.run.manager,
            )
        except ConfigError as exc:
            errors = exc.format().splitlines()
            self._note("reload_failed", errors=errors)
            self._say("invalid", "the changed tree is not valid; the running tree goes on", errors)
            return
        except Exception as exc:  # noqa: BLE001 - a broken file must not end the run
            errors = [f"{self.source}: {type(exc).__name__}: {exc}"]
            self._note("reload_failed", errors=errors)
            self._say(
                "invalid", "the changed tree could not be loaded; the running tree goes on", errors
            )
            return
        self.files = watched_files(tree)
        self._stamps = {p: _stamp(p) for p in self.files}
        self.run.replace_tree(tree)
        waiting = self.run.replacement_waiting
        when = (
            "at the next tick"
            if waiting in (None, "the next tick")
            else f"at the next safe point (now {waiting})"
        )
        self._say("waiting", f"the changed tree is valid; it replaces the running one {when}", [])

    def _note(self, event: str, **data: Any) -> None:
        with self._lock:
            self.pending_events.append({"event": event, "source": str(self.source), **data})

    def _say(self, kind: str, text: str, errors: list[str]) -> None:
        lines = "\n".join(f"  {e}" for e in errors)
        print(f"watch: {text}" + (f"\n{lines}" if lines else ""), file=sys.stderr, flush=True)
        if self.report is not None:
            self.report(kind, text, errors)


__all__ = ["TreeWatcher", "watched_files"]
