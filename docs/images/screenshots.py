"""Make the monitor screenshots in docs/images/ (needs Debian's chromium and playwright).

Usage: python docs/images/screenshots.py
Runs load_ducky.yaml with --monitor and --record, photographs the live page while the
arm picks the ducky (a marker in view), then replays the recording and photographs it
scrubbed to the same moment.
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

from armtree.plugins.monitor.chromium import launch

HERE = Path(__file__).resolve().parent
BIN = Path(sys.executable).parent
VIEW = {"width": 1600, "height": 980}


def start(*args: object, cwd: str | None = None) -> subprocess.Popen:
    """A command whose printed lines are read as text."""
    return subprocess.Popen(
        [str(a) for a in args], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def url_of(proc: subprocess.Popen) -> str:
    for line in proc.stdout:
        found = re.search(r"(?:monitor|replay): (http://\S+)", line)
        if found:
            return found.group(1)
    raise SystemExit(f"no URL printed: {proc.stderr.read()}")


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp, sync_playwright() as p:
        browser = launch(p)
        run = start(
            BIN / "run-tree", "load_ducky.yaml", "--monitor", "0", "--record", "rec", cwd=tmp
        )
        page = browser.new_page(viewport=VIEW, bypass_csp=True)
        page.goto(url_of(run))
        page.wait_for_function("document.querySelectorAll('#tree .node').length > 3")
        page.click("#btn-expand")
        # While the pick looks at the ducky: a marker on the camera, a path on the table.
        page.wait_for_function(
            "() => /[1-9] marker/.test(document.querySelector('#camera-caption').textContent)"
            " && document.body.dataset.letters && document.body.dataset.letters.includes('R')"
            " && Number(document.body.dataset.tick) > 250",
            timeout=120_000,
        )
        time.sleep(0.3)
        tick = int(page.evaluate("document.body.dataset.tick"))
        page.screenshot(path=HERE / "monitor_live.png")
        run.wait(120)
        replay = start(BIN / "armtree", "replay", f"{tmp}/rec", "--port", "0")
        page = browser.new_page(viewport=VIEW, bypass_csp=True)
        page.goto(url_of(replay))
        page.wait_for_function("document.querySelectorAll('#tree .node').length > 3")
        page.click("#btn-expand")
        page.locator("#tl-slider").fill(str(tick + 20))
        page.wait_for_function(f"document.body.dataset.tick === '{tick + 20}'")
        time.sleep(0.5)
        page.screenshot(path=HERE / "monitor_replay.png")
        replay.terminate()
        replay.wait(10)
        browser.close()
    print(f"wrote {HERE / 'monitor_live.png'} and {HERE / 'monitor_replay.png'}")


if __name__ == "__main__":
    main()
