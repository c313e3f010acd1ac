"""The run log's ``feedback`` records: what each node says it is doing, without a line a tick."""

from __future__ import annotations

import math
from collections.abc import Sequence
from itertools import compress
from operator import attrgetter, ne
from typing import Any

#: Run time (s) between two ``feedback`` records of a node whose status did not change.
FEEDBACK_INTERVAL_S = 1.0
_FEEDBACK = attrgetter("feedback_message")


class FeedbackLog:
    """Writes a ``feedback`` record for each node whose ``feedback_message`` changed.

    Always when the node's status changed in the same tick; while its status
    stays the same, at most once per :data:`FEEDBACK_INTERVAL_S` of run time, so
    a countdown does not write a line every tick. Cleared messages are not written.
    """

    def __init__(self, log: Any) -> None:
        self._log = log
        self._nodes: list[Any] = []
        self._paths: Sequence[str] = ()
        self._logged: list[Any] = []
        self._times: list[float] = []

    def reset(self, nodes: list[Any], paths: Sequence[str]) -> None:
        """Follow ``nodes`` (with their ``paths``) from now on; nothing written yet."""
        self._nodes, self._paths = nodes, paths
        self._logged = [""] * len(nodes)
        self._times = [-math.inf] * len(nodes)

    def record(self, tick: int, now: float, last: Sequence[str], current: Sequence[str]) -> None:
        """Write the records due after a tick; ``last`` / ``current``: the status names."""
        messages = list(map(_FEEDBACK, self._nodes))
        logged = self._logged
        if messages == logged:
            return
        times = self._times
        for i in compress(range(len(messages)), map(ne, messages, logged)):
            message = messages[i]
            if not isinstance(message, str):
                message = str(message)
            if not message:
                logged[i] = message
                continue
            if last[i] == current[i] and now - times[i] < FEEDBACK_INTERVAL_S - 1e-9:
                continue
            logged[i], times[i] = messages[i], now
            self._log.write(
                {
                    "kind": "feedback",
                    "tick": tick,
                    "t": now,
                    "node": self._paths[i],
                    "status": current[i],
                    "message": message,
                }
            )
