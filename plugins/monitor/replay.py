"""``armtree replay RUN_DIR``: the monitor page for a recorded run, with a timeline.

The page asks for a tick (``{"type": "seek", "tick": N}``) and gets the full
state after it, and the newest camera frame at or before it; playing at any
speed is the page asking for ticks at that pace.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

from armtree.runtime.interrupts import EXIT_INTERRUPTED

from .ports import replay_port

if TYPE_CHECKING:  # the web server loads when a replay is served, not with the plugin
    from .recorded import Recording
    from .server import Client


class ReplayFeed:
    """Serves one :class:`Recording` to the pages of a :class:`PageServer`."""

    def __init__(self, recording: Recording, host: str, port: int) -> None:
        self.recording = recording
        from .server import PageServer

        self.server = PageServer(self, host, port, option="--port", host_option="--host")

    def hello(self) -> list[dict[str, Any]]:
        """Run description, timeline and the state at tick 0."""
        rec = self.recording
        start = rec.start
        return [
            {
                "type": "hello",
                "mode": "replay",
                "run": {
                    "tree": start.get("tree"),
                    "tick_hz": rec.tick_hz,
                    "clock": start.get("clock"),
                    "seed": start.get("seed"),
                    "record_dir": str(rec.directory),
                },
            },
            {
                "type": "timeline",
                "ticks": rec.ticks,
                "marks": rec.marks(),
                "notice": rec.notice,
                "truncated": rec.truncated,
            },
            self._state(0),
        ]

    def _state(self, tick: int) -> dict[str, Any]:
        state = self.recording.state(tick)
        state["image"] = self.recording.image_at(state["t"]) is not None
        return state

    def on_message(self, client: Client, message: dict[str, Any]) -> None:
        """A seek: the state after that tick, then the camera frame."""
        if message.get("type") != "seek":
            return
        try:
            tick = int(message.get("tick", 0))
        except (TypeError, ValueError):
            return
        state = self._state(tick)
        self.server.send(client, state)
        found = self.recording.image_at(state["t"])
        if found is not None:
            header, jpeg = found
            header["tick"] = state["tick"]
            from .server import image_message

            client.queue.put_nowait(image_message(header, jpeg))

    def on_clients(self, count: int) -> None:
        """Nothing to do: every page replays on its own."""


class ReplayCommand:
    """``armtree replay RUN_DIR``: the monitor page for a recorded run."""

    help = "the monitor page for a recorded run (a timeline to scrub, play at any speed)"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """RUN_DIR, --port, --host."""
        parser.add_argument(
            "run_dir", metavar="RUN_DIR", help="a run directory (run.jsonl, run.mcap)"
        )
        parser.add_argument(
            "--port",
            type=replay_port,
            default=8766,
            help="port of the page (default 8766; 0: any free port)",
        )
        parser.add_argument(
            "--host",
            default="127.0.0.1",
            help="address to serve on (default 127.0.0.1; elsewhere the page needs the printed token)",
        )

    def run(self, args: argparse.Namespace) -> int:
        """Serve until Ctrl-C or SIGTERM (exit 130); exit 2 for a directory that is not a run."""
        from .recorded import Recording

        recording = Recording.open(Path(args.run_dir))
        feed = ReplayFeed(recording, args.host, args.port)
        url = feed.server.start()
        print(f"replay: {url}", flush=True)
        print(
            f"{recording.start.get('tree')}: {recording.ticks} ticks, "
            f"{recording.time(recording.ticks):.2f} s of run time"
            + (f"\n{recording.notice}" if recording.notice else ""),
            flush=True,
        )
        print("Ctrl-C stops the server", file=sys.stderr, flush=True)
        stop = threading.Event()
        previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
        for sig in previous:
            signal.signal(sig, lambda *_: stop.set())
        try:
            while not stop.wait(0.5):
                pass
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
            feed.server.stop(grace=0.2)
        return EXIT_INTERRUPTED


__all__ = ["ReplayCommand", "ReplayFeed"]
