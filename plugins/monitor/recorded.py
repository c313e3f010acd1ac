"""A recorded run read back: run.jsonl, and run.mcap when the run was recorded with ``--record``.

:class:`Recording` answers what the monitor page shows at any tick: statuses,
feedback, the blackboard (with that tick's writes), the events so far, tick
statistics, the scene and the newest camera frame. A recording cut short (a
crash, a kill) is read as far as it goes, and :attr:`Recording.notice` says
where it ends.
"""

from __future__ import annotations

import bisect
import contextlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader

from armtree.errors import ConfigError

from .model import CODES
from .recording import log_level
from .session import tree_of


@dataclass
class Frames:
    """Messages of one channel by log time (ns), for "the newest at or before t"."""

    times: list[int] = field(default_factory=list)
    data: list[bytes] = field(default_factory=list)

    def add(self, ns: int, data: bytes) -> None:
        """Append one message (log times arrive in order, or nearly)."""
        if self.times and ns < self.times[-1]:
            i = bisect.bisect_right(self.times, ns)
            self.times.insert(i, ns)
            self.data.insert(i, data)
        else:
            self.times.append(ns)
            self.data.append(data)

    def at(self, ns: int) -> tuple[int, bytes] | None:
        """The newest message at or before ``ns``."""
        i = bisect.bisect_right(self.times, ns) - 1
        return None if i < 0 else (self.times[i], self.data[i])

    def __len__(self) -> int:
        return len(self.times)


#: The largest run log a replay reads (bytes): its records are held in memory, several
#: times the file's size; a longer run is replayed from a shorter recording.
MAX_LOG_BYTES = 512 * 1024 * 1024


def read_jsonl(path: Path) -> tuple[list[dict[str, Any]], bool]:
    """The records of a run log, and whether its last line was cut off.

    Read line by line: a log over :data:`MAX_LOG_BYTES` is refused by its size, and one
    that does not start with a start record is given back at its first record (the caller
    refuses it) without reading the rest."""
    size = path.stat().st_size
    if size > MAX_LOG_BYTES:
        raise ConfigError(
            f"the run log is {size / 1e6:,.0f} MB, over the {MAX_LOG_BYTES / 1e6:,.0f} MB a "
            "replay reads; replay a shorter run",
            file=str(path),
        )
    records: list[dict[str, Any]] = []
    bad: int | None = None  # a line that is no JSON: an error, unless it is the last
    with path.open("rb") as fh:
        for n, line in enumerate(fh):
            if not line.strip():
                continue
            if bad is not None:
                raise ConfigError(
                    "not a JSON line; is this a run log written by armtree?",
                    file=str(path),
                    line=bad + 1,
                )
            try:
                record = json.loads(line)
            except ValueError:
                bad = n
                continue
            if isinstance(record, dict):
                records.append(record)
                if len(records) == 1 and record.get("kind") != "start":
                    return records, False
    return records, bad is not None


def read_mcap(path: Path) -> tuple[dict[str, Frames], bool]:
    """Every message of ``run.mcap`` by topic, and whether the file was cut short."""
    topics: dict[str, Frames] = {}
    with path.open("rb") as fh:
        try:
            reader = make_reader(fh)
            for _, channel, message in reader.iter_messages(log_time_order=True):
                topics.setdefault(channel.topic, Frames()).add(message.log_time, message.data)
            return topics, False
        except Exception:  # noqa: BLE001 - no summary (cut short): read record by record
            pass
    topics = {}
    channels: dict[int, str] = {}
    cut = True
    with path.open("rb") as fh, contextlib.suppress(Exception):
        for record in StreamReader(fh, skip_magic=False).records:
            if isinstance(record, Channel):
                channels[record.id] = record.topic
            elif isinstance(record, Message) and record.channel_id in channels:
                topic = channels[record.channel_id]
                topics.setdefault(topic, Frames()).add(record.log_time, record.data)
            elif isinstance(record, Schema):
                continue
    return topics, cut


def tree_from_paths(name: str, paths: list[str]) -> dict[str, Any]:
    """A tree description from node paths alone (a run log without a ``tree`` record)."""
    nodes: list[dict[str, Any]] = []
    index: dict[str, int] = {}
    for path in paths:
        parts = path.split("/")
        for depth in range(1, len(parts) + 1):
            sub = "/".join(parts[:depth])
            if sub in index:
                continue
            parent = index.get("/".join(parts[: depth - 1])) if depth > 1 else None
            index[sub] = len(nodes)
            nodes.append(
                {
                    "id": len(nodes),
                    "name": parts[depth - 1],
                    "type": "",
                    "class": "",
                    "kind": "leaf",
                    "path": sub,
                    "file": None,
                    "line": None,
                    "column": None,
                    "params": {},
                    "doc": "",
                    "children": [],
                    "parent": parent,
                }
            )
            if parent is not None:
                nodes[parent]["children"].append(index[sub])
                nodes[parent]["kind"] = "composite"
    return {"name": name, "description": "", "source": "", "tick_hz": 20.0, "nodes": nodes}


class Recording:
    """One run directory read back. :meth:`open` raises :class:`ConfigError` for input
    that is not a run directory."""

    def __init__(self, directory: Path, records: list[dict[str, Any]], cut: bool) -> None:
        self.directory = directory
        self.start = records[0]
        self.tick_hz = float(self.start.get("tick_hz") or 20.0)
        self.result = next((r for r in records if r.get("kind") == "result"), None)
        trees = [r for r in records if r.get("kind") == "tree"]
        statuses = [r for r in records if r.get("kind") == "status"]
        if trees:
            self.trees = [(int(r["tick"]), tree_of(r)) for r in trees]
        else:
            paths = list(dict.fromkeys(r["node"] for r in statuses))
            self.trees = [(0, tree_from_paths(str(self.start.get("tree", "tree")), paths))]
        self.events = [r for r in records if r.get("kind") == "event"]
        self._feedback_records = [r for r in records if r.get("kind") == "feedback"]
        self.writes = [r for r in records if r.get("kind") == "blackboard"]
        self.ticks = max((int(r.get("tick", 0)) for r in records), default=0)
        if self.result is not None:
            self.ticks = max(self.ticks, int(self.result.get("ticks") or 0))
        self._times = {int(r["tick"]): float(r["t"]) for r in records if "t" in r and "tick" in r}
        self._letters = self._status_letters(statuses)
        self.cut = cut
        self.topics: dict[str, Frames] = {}
        self.mcap_cut = False
        mcap = directory / "run.mcap"
        if mcap.is_file():
            self.topics, self.mcap_cut = read_mcap(mcap)
        self.start_ns = self._start_ns()
        self._feedback = self._feedback_by_tick()

    # ------------------------------------------------------------------
    # Opening
    # ------------------------------------------------------------------

    @classmethod
    def open(cls, directory: Path | str) -> Recording:
        """Read the run in ``directory`` (``run.jsonl``, and ``run.mcap`` if there)."""
        directory = Path(directory)
        where = str(directory)
        if not directory.exists():
            raise ConfigError(
                "no such directory; give a run directory (runs/<tree>-<time>/ or a --record DIR)",
                file=where,
            )
        if not directory.is_dir():
            raise ConfigError(
                "not a directory; give the run's directory, not a file in it", file=where
            )
        log = directory / "run.jsonl"
        if not log.is_file():
            raise ConfigError(
                "no run.jsonl here, so this is not a run directory armtree wrote "
                "(run-tree writes one per run: runs/<tree>-<time>/, or the --record DIR)",
                file=where,
            )
        try:
            records, cut = read_jsonl(log)
        except OSError as exc:
            raise ConfigError(f"cannot read it: {exc.strerror or exc}", file=str(log)) from None
        if not records or records[0].get("kind") != "start" or "tick_hz" not in records[0]:
            raise ConfigError(
                "does not start with armtree's start record; is this a run log written by armtree?",
                file=str(log),
                line=1,
            )
        return cls(directory, records, cut)

    # ------------------------------------------------------------------
    # What the page shows
    # ------------------------------------------------------------------

    @property
    def truncated(self) -> bool:
        """True when the run did not end cleanly (no result record, or a file cut short)."""
        return self.result is None or self.cut or self.mcap_cut

    @property
    def notice(self) -> str:
        """What the page says about the recording as a whole (empty when all is well)."""
        notes = []
        if self.result is None:
            notes.append(
                f"This recording ends at tick {self.ticks} (t = {self.time(self.ticks):.2f} s) "
                "with no result: the run was cut short (a crash or a kill); showing what is there."
            )
        elif self.cut:
            notes.append("run.jsonl's last line was cut off; showing what is there.")
        if self.mcap_cut:
            notes.append("run.mcap was cut short (no summary): camera and scene end early.")
        if not self.topics:
            notes.append(
                "No run.mcap here: no camera or scene (record with run-tree --record DIR to keep them)."
            )
        return " ".join(notes)

    def time(self, tick: int) -> float:
        """Run time of ``tick`` (s): from its records, or counted from the tick rate."""
        if tick in self._times:
            return self._times[tick]
        return max(0.0, (tick - 1) / self.tick_hz)

    def tree_at(self, tick: int) -> dict[str, Any]:
        """The tree running at ``tick`` (``--watch`` may have swapped it)."""
        current = self.trees[0][1]
        for start, tree in self.trees:
            if start <= tick:
                current = tree
        return current

    def _status_letters(self, statuses: list[dict[str, Any]]) -> list[tuple[int, dict[str, str]]]:
        """``(tick, {path: letter})`` after each tick that changed a status."""
        current: dict[str, str] = {}
        out: list[tuple[int, dict[str, str]]] = []
        for r in statuses:
            tick = int(r["tick"])
            if out and out[-1][0] == tick:
                out[-1][1][r["node"]] = CODES.get(r["to"], "I")
                current = out[-1][1]
                continue
            current = {**current, r["node"]: CODES.get(r["to"], "I")}
            out.append((tick, current))
        return out

    def letters(self, tick: int) -> str:
        """The statuses after ``tick`` as one letter per node of the tree at that tick."""
        ticks = [t for t, _ in self._letters]
        i = bisect.bisect_right(ticks, tick) - 1
        state = self._letters[i][1] if i >= 0 else {}
        tree = self.tree_at(tick)
        return "".join(state.get(n["path"], "I") for n in tree["nodes"])

    def _feedback_by_tick(self) -> list[tuple[int, dict[str, str]]]:
        """Feedback messages by tick: from run.mcap (every change) or else run.jsonl's
        ``feedback`` records (at most one a second while a node's status stays)."""
        frames = self.topics.get("/armtree/status")
        out: list[tuple[int, dict[str, str]]] = []
        current: dict[str, str] = {}
        if not frames:
            for r in self._feedback_records:
                current = {**current, r["node"]: str(r.get("message") or "")}
                if out and out[-1][0] == int(r["tick"]):
                    out[-1] = (out[-1][0], current)
                else:
                    out.append((int(r["tick"]), current))
            return out
        for data in frames.data:
            with contextlib.suppress(ValueError, KeyError):
                message = json.loads(data)
                if message.get("feedback"):
                    current = {**current, **message["feedback"]}
                    out.append((int(message["tick"]), current))
        return out

    def feedback(self, tick: int) -> dict[str, str]:
        """Each node's feedback message after ``tick`` (by node index), where recorded."""
        ticks = [t for t, _ in self._feedback]
        i = bisect.bisect_right(ticks, tick) - 1
        if i < 0:
            return {}
        by_path = self._feedback[i][1]
        tree = self.tree_at(tick)
        return {str(n["id"]): by_path[n["path"]] for n in tree["nodes"] if by_path.get(n["path"])}

    def blackboard(self, tick: int) -> tuple[dict[str, Any], list[str]]:
        """The blackboard after ``tick``, and the keys that tick wrote."""
        values = {
            (k if k.startswith("/") else "/" + k): v
            for k, v in (self.start.get("blackboard") or {}).items()
        }
        written = []
        for r in self.writes:
            if r["tick"] > tick:
                break
            values[r["key"]] = r.get("value")
            if r["tick"] == tick:
                written.append(r["key"])
        return dict(sorted(values.items())), written

    def events_until(self, tick: int) -> list[dict[str, Any]]:
        """The events logged at or before ``tick``."""
        return [r for r in self.events if int(r.get("tick", 0)) <= tick]

    def _start_ns(self) -> int:
        frames = self.topics.get("/armtree/events")
        if frames:
            for ns, data in zip(frames.times, frames.data, strict=True):
                with contextlib.suppress(ValueError):
                    record = json.loads(data)
                    return ns - round(float(record.get("t", 0.0)) * 1e9)
        return 0

    def _newest(self, topic: str, t: float) -> tuple[int, bytes] | None:
        frames = self.topics.get(topic)
        if not frames:
            return None
        return frames.at(self.start_ns + round(t * 1e9) + 1)

    def json_at(self, topic: str, t: float) -> dict[str, Any] | None:
        """The newest JSON message of ``topic`` at or before run time ``t``."""
        found = self._newest(topic, t)
        if found is None:
            return None
        try:
            return json.loads(found[1])
        except ValueError:
            return None

    def image_at(self, t: float) -> tuple[dict[str, Any], bytes] | None:
        """The newest camera frame at or before ``t``: (header with detections, JPEG bytes)."""
        found = self._newest("/camera/image", t)
        if found is None:
            return None
        import base64

        ns, data = found
        message = json.loads(data)
        seconds = (ns - self.start_ns) / 1e9
        detections = self.json_at("/armtree/detections", seconds)
        if detections is not None and abs(float(detections.get("t", -1)) - seconds) > 1e-6:
            detections = None
        header = {"type": "image", "t": seconds, "detections": detections or {"markers": []}}
        return header, base64.b64decode(message["data"])

    def marks(self) -> list[dict[str, Any]]:
        """Ticks worth a mark on the timeline: events, and the result."""
        marks = [
            {"tick": int(r["tick"]), "label": str(r.get("event")), "level": log_level(r)}
            for r in self.events
        ]
        if self.result is not None:
            marks.append(
                {
                    "tick": int(self.result.get("tick", self.ticks)),
                    "label": f"result: {self.result.get('status')}",
                    "level": log_level(self.result),
                }
            )
        return marks

    def state(self, tick: int) -> dict[str, Any]:
        """The page's full state after ``tick`` (clamped to the recording)."""
        tick = max(0, min(self.ticks, int(tick)))
        t = self.time(tick)
        blackboard, written = self.blackboard(tick)
        stats = self.json_at("/armtree/ticks", t) or {}
        return {
            "type": "state",
            "tree": self.tree_at(tick),
            "tick": tick,
            "t": t,
            "letters": self.letters(tick),
            "feedback": self.feedback(tick),
            "blackboard": blackboard,
            "written": written,
            "events": self.events_until(tick),
            "stats": stats,
            "result": self.result if self.result is not None and tick >= self.ticks else None,
            "scene": self.json_at("/armtree/scene", t),
            "control": "replay",
            "image_note": "no camera in this recording" if not self.topics else "",
        }


__all__ = ["Frames", "Recording", "read_jsonl", "read_mcap", "tree_from_paths"]
