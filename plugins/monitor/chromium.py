"""Debian's chromium, headless, as armtree's browser tests, benchmarks and screenshots start it.

Playwright drives the system's browser (``/usr/bin/chromium``, or ``ARMTREE_CHROMIUM``):
nothing is downloaded. The flags keep it quiet on a machine with no display and a
closed network (no sandbox when running as root, no GPU, no background traffic).
"""

from __future__ import annotations

import os

#: Where the browser is.
CHROMIUM = os.environ.get("ARMTREE_CHROMIUM", "/usr/bin/chromium")

#: Flags for a headless run with no display and a closed network.
CHROMIUM_ARGS = (
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
)


def launch(playwright: object) -> object:
    """A headless Chromium Browser from a started ``sync_playwright()``."""
    return playwright.chromium.launch(  # type: ignore[attr-defined]
        executable_path=CHROMIUM, headless=True, args=list(CHROMIUM_ARGS)
    )


__all__ = ["CHROMIUM", "CHROMIUM_ARGS", "launch"]
