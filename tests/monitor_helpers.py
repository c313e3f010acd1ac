"""Shared by the monitor tests: a recorded run, run-tree with --monitor, a headless browser."""

from __future__ import annotations

import contextlib
import importlib.metadata
import json
import queue
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import aiohttp
import pytest

from armtree.cli.commandline import run_tree_main
from armtree.plugins.monitor.chromium import CHROMIUM, launch

RUN_TREE = Path(sys.executable).with_name("run-tree")
ARMTREE = Path(sys.executable).with_name("armtree")

#: Statuses that change for a few ticks, then a leaf that runs until stopped.
COUNT_TREE = """\
tree: count
tick_hz: 20
root:
  sequence:
    name: Root
    children:
      - tick_counter: {name: Count, duration: 30}
      - running: {name: Wait}
"""

#: Only the core plugins and the monitor: these runs need no arm, camera or skill.
ONLY_MONITOR = [
    arg
    for ep in importlib.metadata.entry_points(group="armtree")
    if ep.name not in ("core_behaviours", "core_commands", "monitor")
    for arg in ("-p", f"no:{ep.name}")
]


def record_run(base: Path) -> Path:
    """Run the shipped pick_and_place.yaml on the simulated Dobot with ``--record``; the
    run directory (it looks, grasps, writes the blackboard and places)."""
    out = base / "run"
    code = run_tree_main(["pick_and_place.yaml", "--record", str(out), "--quiet"])
    assert code == 0
    return out


class Proc:
    """A command whose stdout lines can be awaited with a timeout."""

    def __init__(self, args: list[str], cwd: Path, stdin=None) -> None:
        self.p = subprocess.Popen(
            [str(a) for a in args],
            cwd=cwd,
            stdin=stdin if stdin is not None else subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.lines: queue.Queue = queue.Queue()
        self.seen: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.p.stdout:
            self.lines.put(line)
        self.lines.put(None)

    def wait_for(self, pattern: str, timeout: float = 60.0) -> re.Match:
        """The first stdout line matching ``pattern`` (a regex)."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                line = self.lines.get(timeout=max(0.01, deadline - time.monotonic()))
            except queue.Empty:
                raise AssertionError(
                    f"no {pattern!r} within {timeout} s: {''.join(self.seen)}"
                ) from None
            if line is None:
                err = self.p.stderr.read()
                raise AssertionError(f"ended before {pattern!r}: {''.join(self.seen)}{err}")
            self.seen.append(line)
            found = re.search(pattern, line)
            if found:
                return found

    def url(self, timeout: float = 60.0) -> str:
        """The monitor's or the replay's URL, once printed."""
        return self.wait_for(r"(?:monitor|replay): (http://\S+)", timeout).group(1)

    def finish(self, timeout: float) -> tuple[int, str]:
        """Exit code and stderr; kills the process if it is not gone within ``timeout`` s."""
        try:
            code = self.p.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.p.kill()
            raise
        return code, self.p.stderr.read()

    def interrupt(self, timeout: float = 20.0) -> tuple[int, str]:
        """Ctrl-C: SIGINT, then the exit code and stderr."""
        self.p.send_signal(signal.SIGINT)
        return self.finish(timeout)

    def kill(self) -> None:
        """End it if it still runs."""
        if self.p.poll() is None:
            self.p.kill()
            self.p.wait(5)


def run_tree(*args: str, cwd: Path) -> Proc:
    """``run-tree ARGS`` with only the core and monitor plugins."""
    return Proc([RUN_TREE, *args, *ONLY_MONITOR], cwd)


def _browser_missing() -> str | None:
    """Why the browser tests cannot run here, or None."""
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "playwright is not installed (pip install playwright; .ci/run installs it)"
    if not (Path(CHROMIUM).exists() or shutil.which(CHROMIUM)):
        return f"no Chromium at {CHROMIUM} (apt-get install chromium; .ci/run installs it)"
    return None


#: Why the browser tests skip (None: they run).
BROWSER_MISSING = _browser_missing()
#: Mark for tests that need headless Chromium.
needs_browser = pytest.mark.skipif(BROWSER_MISSING is not None, reason=str(BROWSER_MISSING))


@contextlib.contextmanager
def chromium():
    """A headless Chromium (playwright Browser), closed afterwards."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = launch(p)
        try:
            yield browser
        finally:
            browser.close()


class Page:
    """One open monitor page, seen through its websocket."""

    def __init__(self, ws, session):
        self.ws = ws
        self.session = session
        self.messages = []

    @classmethod
    async def open(cls, url):
        session = aiohttp.ClientSession()
        base, _, query = url.partition("?")
        ws = await session.ws_connect(base.rstrip("/") + "/ws" + (f"?{query}" if query else ""))
        return cls(ws, session)

    async def next(self, kind, check=lambda m: True, timeout=20.0):
        """The next message of ``kind`` for which ``check`` holds."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            assert left > 0, f"no {kind} message within {timeout} s"
            msg = await self.ws.receive(timeout=left)
            if msg.type == aiohttp.WSMsgType.BINARY:
                continue
            assert msg.type == aiohttp.WSMsgType.TEXT, msg
            data = json.loads(msg.data)
            self.messages.append(data)
            if data.get("type") == kind and check(data):
                return data

    async def send(self, **message):
        await self.ws.send_str(json.dumps(message))

    async def close(self):
        await self.ws.close()
        await self.session.close()
