"""What plugins see of a sweep (``armtree sweep``): the :class:`Sweep` its hooks are handed."""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .views import TreeView


@dataclass
class Sweep:
    """A sweep as its hooks see it: the loaded tree, the seeds, the report folder,
    the plugins' option values (handed to every run), what plugins keep for it (each
    under a key of its own), modules its runs will import (``preload``: a local sweep's
    run process imports them once, and each run starts with them loaded) and closers
    run at its end, newest first, whatever happened."""

    tree: TreeView
    seeds: Sequence[int]
    out: Path
    settings: dict[str, Any] = field(default_factory=dict)
    plugin_state: dict[str, Any] = field(default_factory=dict)
    preload: list[str] = field(default_factory=list)
    closers: list[Callable[[], None]] = field(default_factory=list)

    def close(self) -> None:
        """Run the closers, newest first; one that raises does not keep the rest."""
        while self.closers:
            closer = self.closers.pop()
            try:
                closer()
            except Exception as exc:  # noqa: BLE001 - reported, the others still run
                print(f"warning: closing the sweep: {type(exc).__name__}: {exc}", file=sys.stderr)
