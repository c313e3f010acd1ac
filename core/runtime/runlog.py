"""The run log: one JSON object per line, written as the run goes and flushed on every exit.

Records (every one has ``tick`` and ``t``, seconds on the run's clock):

* ``{"kind": "start", "tree": ..., "seed": ..., "tick_hz": ..., "clock": "virtual"|"wall", ...}``
* ``{"kind": "status", "node": "Root/Child", "from": "INVALID", "to": "RUNNING"}``
  for every status change of every node, with ``"why"`` (the node's feedback
  message) when it turns FAILURE;
* ``{"kind": "feedback", "node": "Root/Child", "status": "SUCCESS", "message": "..."}``
  when a node's ``feedback_message`` changes: always with a status change, at
  most once a second of run time while the status stays the same;
* ``{"kind": "blackboard", "key": "/pose", "op": "WRITE", "client": ..., "value": ...}``
  for blackboard writes (py_trees' activity stream);
* ``{"kind": "event", "event": "preempt"|"interrupt"|"exception"|"hook_error"|..., ...}``;
* ``{"kind": "result", "status": "SUCCESS"|"FAILURE"|"INTERRUPTED", ...}`` last.
"""

from __future__ import annotations

import json
import re
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from itertools import compress
from operator import ne
from pathlib import Path
from typing import Any, BinaryIO, Protocol

from armtree.api.clock import Clock

_UNSAFE = re.compile(r"[^A-Za-z0-9_.-]+")
#: Whole-tick status transitions remembered by :meth:`RunLog.status_diff`; when that
#: many are held they are forgotten, and no more are kept if fewer ticks than that
#: were served from them meanwhile (the tree does not repeat itself).
_TICK_PATTERNS = 256


def default_run_dir(tree_name: str, base: Path | str = "runs") -> Path:
    """A fresh ``runs/<tree>-<YYYYmmdd-HHMMSS>[-N]`` directory (created)."""
    base = Path(base)
    # One short, safe folder name inside ``base``, whatever a tree file calls itself.
    name = _UNSAFE.sub("_", tree_name).strip(".")[:80] or "tree"
    stem = f"{name}-{time.strftime('%Y%m%d-%H%M%S')}"
    candidate = base / stem
    n = 1
    while True:
        try:
            candidate.mkdir(parents=True, exist_ok=False)
            return candidate
        except FileExistsError:
            n += 1
            candidate = base / f"{stem}-{n}"


def jsonable(value: Any, depth: int = 0) -> Any:
    """``value`` made JSON-safe: containers kept, numpy arrays as lists, the rest as ``repr``."""
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        return value if value == value and abs(value) != float("inf") else repr(value)
    if depth < 4:
        if isinstance(value, dict):
            return {str(k): jsonable(v, depth + 1) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [jsonable(v, depth + 1) for v in value]
        tolist = getattr(value, "tolist", None)
        if callable(tolist):
            try:
                return jsonable(tolist(), depth + 1)
            except Exception:  # noqa: BLE001 - fall back to repr for odd objects
                pass
    text = repr(value)
    return text if len(text) <= 200 else text[:197] + "..."


class RunLog:
    """Append-only JSON-lines log of one run at ``path`` (``None``: keep nothing).

    Status records are the hot path (one per node status change); each line's
    end is built once per (node, from, to) and reused.
    """

    def __init__(self, path: Path | None) -> None:
        self.path = path
        self._file: BinaryIO | None = None
        # Hot path: the end of a status line, per (path, from, to), built once.
        # Bytes, so a tick's lines are joined and written without a text-encoding pass.
        self._tails: dict[tuple[str, Any, Any], bytes] = {}
        # Trees that repeat (loops, polling, periodic skills) go through the same
        # whole-tree transitions again and again: a tick's line ends, per (old, new)
        # of the paths last given.
        self._ticks: dict[tuple[Sequence[str], Sequence[str]], list[bytes]] = {}
        self._tick_paths: Sequence[str] | None = None
        self._tick_hits = 0
        self._remember = True
        #: Called with every record written through :meth:`write` (events, blackboard,
        #: start, result; not the status lines), for live views.
        self.listeners: list[Callable[[dict[str, Any]], None]] = []
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._file = path.open("wb", buffering=1 << 16)

    @property
    def enabled(self) -> bool:
        """True while records are being written."""
        return self._file is not None

    def write(self, record: dict[str, Any]) -> None:
        """Append one record (made JSON-safe) and hand it to the listeners."""
        if self._file is not None:
            self._file.write((json.dumps(jsonable(record)) + "\n").encode())
        for listener in self.listeners:
            listener(record)

    def status_changes(self, tick: int, t: float, changes: Iterable[tuple[str, Any, Any]]) -> None:
        """Append one ``status`` record per ``(node_path, from, to)`` (py_trees Status or name)."""
        if self._file is None:
            return
        get, make = self._tails.get, self._tail
        parts = [get(change) or make(change) for change in changes]
        if parts:
            head = f'{{"kind": "status", "tick": {tick}, "t": {t!r}, "node": '.encode()
            self._file.write(head + head.join(parts))

    def status_diff(
        self,
        tick: int,
        t: float,
        paths: Sequence[str],
        old: Sequence[str],
        new: Sequence[str],
        why: Mapping[str, str] | None = None,
    ) -> None:
        """Append a ``status`` record for every node whose status name differs in ``old`` and ``new``.

        ``paths``, ``old`` and ``new`` run in parallel: node path, status name
        (``"RUNNING"``...) before and after a tick. The same records as
        :meth:`status_changes` with the changed ``(path, old, new)``, in node
        order. Given as tuples, a tick's lines are remembered for the next time
        the tree makes the same changes (while that pays: see ``_TICK_PATTERNS``).
        ``why`` maps paths of nodes that turned FAILURE to their reasons; their
        records get a ``"why"`` field.
        """
        if self._file is None:
            return
        ticks = self._ticks
        if paths is not self._tick_paths:
            ticks.clear()
            self._tick_paths, self._tick_hits = paths, 0
            self._remember = isinstance(old, tuple) and isinstance(new, tuple)
        if not self._remember:
            parts = self._diff_tails(paths, old, new)
        else:
            key = (old, new)
            try:
                known = ticks.get(key)
            except TypeError:  # lists after tuples: nothing to remember them by
                parts = self._diff_tails(paths, old, new)
            else:
                if known is None:
                    parts = self._diff_tails(paths, old, new)
                    if len(ticks) >= _TICK_PATTERNS:
                        # Full: a tree that hardly repeats itself stops paying for the look-ups.
                        self._remember = self._tick_hits >= len(ticks)
                        ticks.clear()
                        self._tick_hits = 0
                    ticks[key] = parts
                else:
                    parts = known
                    self._tick_hits += 1
        if why:
            parts = self._with_reasons(paths, old, new, why)
        if parts:
            head = f'{{"kind": "status", "tick": {tick}, "t": {t!r}, "node": '.encode()
            self._file.write(head + head.join(parts))

    def _diff_tails(
        self, paths: Sequence[str], old: Sequence[str], new: Sequence[str]
    ) -> list[bytes]:
        # Run entirely in C (no bytecode per node): the changed nodes are picked with
        # compress/ne (names of the same status are one object, so ``ne`` is an identity
        # check) and zip's (path, from, to) is the line cache's key itself.
        changed = compress(zip(paths, old, new, strict=True), map(ne, old, new))
        try:
            return list(map(self._tails.__getitem__, changed))
        except KeyError:
            # A transition not seen before: build and cache its line.
            get, make = self._tails.get, self._tail
            return [
                get(change) or make(change)
                for change in compress(zip(paths, old, new, strict=True), map(ne, old, new))
            ]

    def _with_reasons(
        self, paths: Sequence[str], old: Sequence[str], new: Sequence[str], why: Mapping[str, str]
    ) -> list[bytes]:
        # Rare (a node failing): built each time, never cached.
        parts = []
        for change in compress(zip(paths, old, new, strict=True), map(ne, old, new)):
            path, before, after = change
            if path in why:
                reason = json.dumps(why[path])
                parts.append(
                    f'{json.dumps(path)}, "from": "{_name(before)}", "to": "{_name(after)}", '
                    f'"why": {reason}}}\n'.encode()
                )
            else:
                parts.append(self._tails.get(change) or self._tail(change))
        return parts

    def _tail(self, change: tuple[str, Any, Any]) -> bytes:
        path, old, new = change
        tail = f'{json.dumps(path)}, "from": "{_name(old)}", "to": "{_name(new)}"}}\n'.encode()
        self._tails[change] = tail
        return tail

    def event(self, tick: int, t: float, event: str, **data: Any) -> None:
        """Append an ``event`` record."""
        self.write({"kind": "event", "tick": tick, "t": t, "event": event, **data})

    def flush(self) -> None:
        """Push everything written so far to the file system."""
        if self._file is not None:
            self._file.flush()

    def close(self) -> None:
        """Flush and close; safe to call twice."""
        if self._file is not None:
            file, self._file = self._file, None
            try:
                file.flush()
            finally:
                file.close()


class LoggedRun(Protocol):
    """What a run's helpers read to write a record: the log, the tick and the clock."""

    log: RunLog
    tick_count: int
    clock: Clock


def _name(status: Any) -> str:
    return str(getattr(status, "value", status))


def read_log(path: Path | str) -> list[dict[str, Any]]:
    """Every record of a run log, in order."""
    with Path(path).open(encoding="utf-8") as fh:
        return [json.loads(line) for line in fh if line.strip()]
