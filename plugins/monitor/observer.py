"""What one tick changed, sampled on the run's own thread and kept cheap.

:class:`RunObserver` is called after every tick (``armtree_tick``); it looks
at the statuses only when the runtime made a new tuple of them, reads the
feedback of nodes that are not INVALID, takes the tick's blackboard writes,
and times the ticks. Its :class:`TickSample` objects are plain data handed to
the recording's writer thread and the page's server thread.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from py_trees.blackboard import Blackboard

from armtree.runtime.runlog import jsonable
from armtree.runtime.runner import Run

from .model import describe_tree, status_letters


@dataclass
class TickSample:
    """One tick as seen from outside.

    ``letters``: one status letter per node; ``changed``: whether any status
    changed in this tick; ``feedback``: ``{node index: message}`` of the nodes
    whose message changed (``""`` when cleared); ``writes``: blackboard keys
    written in this tick with their values (JSON-safe); ``tick_ms``: the wall
    time the tick took; ``wall``: ``time.time()`` when it was sampled.
    """

    tick: int
    t: float
    wall: float
    letters: str
    changed: bool
    feedback: dict[int, str]
    writes: dict[str, Any]
    tick_ms: float
    overruns: int


@dataclass
class TickRate:
    """Ticks per wall second and tick times over the last ``window`` ticks."""

    window: int = 40
    _walls: deque = field(default_factory=lambda: deque(maxlen=41))
    _ms: deque = field(default_factory=lambda: deque(maxlen=40))

    def add(self, wall: float, tick_ms: float) -> None:
        """Count one tick that ended at ``wall`` (s) and took ``tick_ms``."""
        self._walls.append(wall)
        self._ms.append(tick_ms)

    def summary(self) -> dict[str, float]:
        """``rate_hz`` (per wall second), ``tick_ms_mean`` and ``tick_ms_max``."""
        walls, ms = self._walls, self._ms
        span = walls[-1] - walls[0] if len(walls) > 1 else 0.0
        return {
            "rate_hz": (len(walls) - 1) / span if span > 0 else 0.0,
            "tick_ms_mean": sum(ms) / len(ms) if ms else 0.0,
            "tick_ms_max": max(ms) if ms else 0.0,
        }


class RunObserver:
    """Samples a run after each tick; keeps the tree, the blackboard and the events so far."""

    def __init__(self, run: Run) -> None:
        self.run = run
        self.tree = describe_tree(run.tree, run.nodes)
        self._nodes = run.nodes
        self._statuses: Any = None
        self._letters = status_letters(run.statuses)
        self._feedback: list[str] = [""] * len(self._nodes)
        self.blackboard: dict[str, Any] = {
            k: jsonable(v) for k, v in sorted(Blackboard.storage.items())
        }
        self.rate = TickRate()
        self.last: TickSample | None = None

    @property
    def letters(self) -> str:
        """The statuses after the last sample."""
        return self._letters

    def reindex(self) -> None:
        """The run swapped in another tree (``--watch``): describe it afresh."""
        self.tree = describe_tree(self.run.tree, self.run.nodes)
        self._nodes = self.run.nodes
        self._statuses = None
        self._letters = status_letters(self.run.statuses)
        self._feedback = [""] * len(self._nodes)

    def sample(self) -> TickSample:
        """What the tick that just ended changed."""
        run = self.run
        statuses = run.statuses
        changed = statuses is not self._statuses
        if changed:
            self._statuses = statuses
            letters = status_letters(statuses)
            changed = letters != self._letters
            self._letters = letters
        feedback: dict[int, str] = {}
        old = self._feedback
        letters = self._letters
        for i, node in enumerate(self._nodes):
            message = node.feedback_message if letters[i] != "I" else old[i]
            if message != old[i]:
                old[i] = message
                feedback[i] = message
        writes = {}
        for key, value in run.tick_writes:
            shown = jsonable(value)
            writes[key] = shown
            self.blackboard[key] = shown
        wall = time.time()
        tick_ms = run.tick_wall * 1000.0
        self.rate.add(time.monotonic(), tick_ms)
        sample = TickSample(
            tick=run.tick_count,
            t=run.tick_time,
            wall=wall,
            letters=letters,
            changed=changed,
            feedback=feedback,
            writes=writes,
            tick_ms=tick_ms,
            overruns=run.overruns,
        )
        self.last = sample
        return sample


__all__ = ["RunObserver", "TickRate", "TickSample"]
