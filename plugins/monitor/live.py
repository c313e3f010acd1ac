"""What feeds the page during a run: tick deltas, events, camera frames, the scene, controls.

The run's thread only merges each tick into a pending delta under a lock and,
if none is on its way, asks the server's thread to flush it; everything else
(building messages, JPEG encoding, scene sampling) happens on the server's
thread or its executor. At most :data:`FLUSH_HZ` deltas, :data:`IMAGE_HZ`
camera frames and :data:`SCENE_HZ` scenes go out per wall second, and a frame
only to a page that has drawn the previous one.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import Any

from armtree.runtime.runlog import jsonable
from armtree.runtime.runner import Run

from .observer import TickRate, TickSample
from .recording import detections_json, jpeg
from .scene import SceneSampler
from .server import Client, PageServer, image_message

FLUSH_HZ = 30.0
IMAGE_HZ = 15.0
SCENE_HZ = 10.0
#: Events kept for pages opened late.
_EVENTS_KEPT = 500
#: Page controls and what they call on ``run.control``.
_ACTIONS = ("pause", "resume", "step", "stop", "speed")


class LiveFeed:
    """Feeds one run to the pages of a :class:`PageServer` and takes their controls."""

    def __init__(self, run: Run, host: str, port: int) -> None:
        self.run = run
        self.session: Any = None
        self.server = PageServer(self, host, port)
        self._lock = threading.Lock()
        self._pending: dict[str, Any] = {}
        self._flush_due = False
        self._last_flush = 0.0
        self._rate = TickRate()
        # Page state, touched only on the server's thread.
        self.tree: dict[str, Any] | None = None
        self.letters = ""
        self.feedback: dict[int, str] = {}
        self.blackboard: dict[str, Any] = {}
        self.written: list[str] = []
        self.events: list[dict[str, Any]] = []
        self.tick = 0
        self.t = 0.0
        self.stats: dict[str, Any] = {}
        self.result: dict[str, Any] | None = None
        self.scene: dict[str, Any] | None = None
        self.reload_error: dict[str, Any] | None = None
        self.clients = 0
        self._scene_sampler: SceneSampler | None = None
        self._image_seq = -1
        self._busy_image = False
        self._busy_scene = False
        self._next_scene = 0.0
        self._closed = False

    def start(self) -> str:
        """Bind the server (a :class:`ConfigError` if it cannot) and start the pumps; the URL."""
        url = self.server.start()
        self.server.call(self._pump)
        return url

    # ------------------------------------------------------------------
    # From the run's thread (the session's feed interface)
    # ------------------------------------------------------------------

    def on_tree(self, session: Any) -> None:
        """The session started, or swapped in a new tree."""
        self.session = session
        observer = session.observer
        tree = observer.tree
        letters = observer.letters
        blackboard = dict(observer.blackboard)
        self._scene_sampler = SceneSampler(self.run, session.taps)
        self.server.call(self._set_tree, tree, letters, blackboard)

    def on_tick(self, session: Any, sample: TickSample) -> None:
        """Merge the tick into the pending delta; ask for a flush if none is due."""
        with self._lock:
            pending = self._pending
            pending["tick"] = sample.tick
            pending["t"] = sample.t
            pending["wall"] = sample.wall
            pending["letters"] = sample.letters
            if sample.feedback:
                pending.setdefault("feedback", {}).update(sample.feedback)
            if sample.writes:
                pending.setdefault("written", {}).update(sample.writes)
            pending["overruns"] = sample.overruns
            self._rate.add(time.monotonic(), sample.tick_ms)
            if self._flush_due:
                return
            self._flush_due = True
        self.server.call(self._flush_soon)

    def on_record(self, session: Any, record: dict[str, Any]) -> None:
        """An event or the result, delivered in order with the ticks."""
        with self._lock:
            self._pending.setdefault("records", []).append(jsonable(record))
            if self._flush_due:
                return
            self._flush_due = True
        self.server.call(self._flush_soon)

    def on_state(self, session: Any, state: str) -> None:
        """The run's control changed state: tell the pages now, after the ticks before it."""
        with self._lock:
            self._pending["control"] = {
                "type": "control",
                "state": state,
                "tick": self.run.tick_count,
            }
        self.server.call(self._flush)

    def on_watch(self, session: Any, kind: str, text: str, errors: list[str]) -> None:
        """The tree watcher's news: an invalid change (kept for pages opened later), a
        valid one waiting for a safe point, or the swap."""
        news = {"kind": kind, "text": text, "errors": errors}
        self.server.call(self._set_watch, news)

    def on_close(self, session: Any) -> None:
        """The run is over: last delta, the end, then close the pages."""
        if self._closed:
            return
        self._closed = True
        done = threading.Event()

        def last() -> None:
            self._flush()
            self.server.broadcast({"type": "end", "result": self.result})
            done.set()

        self.server.call(last)
        done.wait(2.0)
        self.server.stop()

    # ------------------------------------------------------------------
    # On the server's thread
    # ------------------------------------------------------------------

    def _set_tree(self, tree: dict[str, Any], letters: str, blackboard: dict[str, Any]) -> None:
        self.tree = tree
        self.letters = letters
        self.feedback = {}
        self.blackboard = blackboard
        self.reload_error = None
        for message in self.hello()[1:2]:
            self.server.broadcast(message)

    def _set_watch(self, news: dict[str, Any]) -> None:
        self.reload_error = news if news["kind"] == "invalid" else None
        self.server.broadcast({"type": "watch", **news})

    def _flush_soon(self) -> None:
        delay = self._last_flush + 1.0 / FLUSH_HZ - time.monotonic()
        if delay > 0 and self.server.loop is not None:
            self.server.loop.call_later(delay, self._flush)
        else:
            self._flush()

    def _flush(self) -> None:
        with self._lock:
            pending, self._pending = self._pending, {}
            self._flush_due = False
            stats = self._rate.summary()
        self._last_flush = time.monotonic()
        if not pending:
            return
        control = pending.pop("control", None)
        records = pending.pop("records", [])
        for record in records:
            if record.get("kind") == "result":
                self.result = record
            else:
                self.events.append(record)
        del self.events[:-_EVENTS_KEPT]
        if "tick" in pending:
            self.tick, self.t = pending["tick"], pending["t"]
            self.letters = pending["letters"]
            for i, message in pending.get("feedback", {}).items():
                self.feedback[i] = message
            written = pending.get("written", {})
            self.blackboard.update(written)
            self.written = list(written)
            self.stats = {**stats, "overruns": pending["overruns"]}
        message = {
            "type": "tick",
            "tick": self.tick,
            "t": self.t,
            "wall": pending.get("wall"),
            "letters": self.letters,
            "feedback": {str(k): v for k, v in pending.get("feedback", {}).items()},
            "written": pending.get("written", {}),
            "stats": self.stats,
            "records": records,
        }
        if "tick" in pending or records:
            self.server.broadcast(message)
        if control is not None:
            self.server.broadcast(control)

    def hello(self) -> list[dict[str, Any]]:
        """A run description and a full snapshot, for a page that just opened."""
        run = self.run
        messages: list[dict[str, Any]] = [
            {
                "type": "hello",
                "mode": "live",
                "run": {
                    "tree": run.tree.name,
                    "tick_hz": run.tick_hz,
                    "clock": "virtual" if run.clock.virtual else "wall",
                    "seed": run.seed,
                    "record_dir": str(run.record_dir) if run.record_dir else None,
                    "speed": run.control.speed,
                },
            }
        ]
        if self.tree is not None:
            messages.append(
                {
                    "type": "state",
                    "tree": self.tree,
                    "tick": self.tick,
                    "t": self.t,
                    "letters": self.letters,
                    "feedback": {str(k): v for k, v in self.feedback.items() if v},
                    "blackboard": self.blackboard,
                    "written": self.written,
                    "events": self.events,
                    "stats": self.stats,
                    "result": self.result,
                    "control": run.control.state,
                    "scene": self.scene,
                    "reload_error": self.reload_error,
                }
            )
        return messages

    def on_message(self, client: Client, message: dict[str, Any]) -> None:
        """A control from a page: pause, resume, step, stop, speed (acted on once)."""
        if message.get("type") != "control" or message.get("action") not in _ACTIONS:
            return
        control = self.run.control
        action = message["action"]
        if action == "pause":
            control.pause()
        elif action == "resume":
            control.resume()
        elif action == "step":
            control.step()
        elif action == "stop":
            control.stop("stop from the monitor page")
        elif action == "speed" and self.run.clock.virtual:
            value = message.get("value")
            try:
                control.speed = None if value in (None, "max") else float(value)
            except (TypeError, ValueError):
                return
            self.server.broadcast({"type": "speed", "speed": control.speed})

    def on_clients(self, count: int) -> None:
        """Tell the pages how many are open; say so in the terminal when the last one closes."""
        before, self.clients = self.clients, count
        self.server.broadcast({"type": "clients", "count": count})
        if count == 0 and before > 0 and self.run.control.holding and not self._closed:
            print(
                "monitor: the last page closed while the run is paused; it stays paused "
                f"(reopen {self.server.url}, or press r in the terminal; Ctrl-C stops it)",
                file=sys.stderr,
                flush=True,
            )

    def _pump(self) -> None:
        """Every 1/IMAGE_HZ s: a new camera frame and, less often, the scene, to open pages."""
        loop = self.server.loop
        if loop is None or self._closed:
            return
        loop.call_later(1.0 / IMAGE_HZ, self._pump)
        if not self.server.clients or self.session is None:
            return
        taps = self.session.taps
        seen = taps.shown() if taps is not None else None
        if (
            seen is not None
            and seen.seq != self._image_seq
            and not self._busy_image
            and self.server.any_ready_for_image
        ):
            self._busy_image = True
            self._image_seq = seen.seq
            loop.run_in_executor(None, self._encode, seen, self.tick, self.t)
        now = time.monotonic()
        if self._scene_sampler is not None and not self._busy_scene and now >= self._next_scene:
            self._busy_scene = True
            self._next_scene = now + 1.0 / SCENE_HZ
            loop.run_in_executor(None, self._sample_scene)

    def _encode(self, seen: Any, tick: int, t: float) -> None:
        try:
            header = {
                "type": "image",
                "tick": tick,
                "t": float(seen.frame.timestamp),
                "detections": detections_json(seen, tick, t),
            }
            self.server.broadcast_binary(image_message(header, jpeg(seen.frame.image)))
        finally:
            self._busy_image = False

    def _sample_scene(self) -> None:
        try:
            sampler = self._scene_sampler
            if sampler is None:
                return
            scene = sampler.sample()
            self.server.call(self._set_scene, scene)
        except Exception:  # noqa: BLE001 - a picture must never break the run
            pass
        finally:
            self._busy_scene = False

    def _set_scene(self, scene: dict[str, Any]) -> None:
        self.scene = scene
        self.server.broadcast({"type": "scene", "scene": scene})


__all__ = ["LiveFeed"]
