"""A run's blackboard: it starts from the tree's own values, and each tick's writes go
from py_trees' activity stream into the run log."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from py_trees.blackboard import ActivityType, Blackboard

from .runlog import RunLog, jsonable

#: Blackboard activities written to the run log.
LOGGED_ACTIVITIES = frozenset(
    {ActivityType.WRITE.value, ActivityType.INITIALISED.value, ActivityType.UNSET.value}
)


class BlackboardLog:
    """The blackboard of one run, and its ``blackboard`` records.

    :meth:`start` clears py_trees' process-wide blackboard and writes the tree's
    initial values; while the run is logged, py_trees' activity stream is on and
    :meth:`record` writes each tick's writes (keeping them in :attr:`writes`);
    :meth:`stop` turns the stream off.
    """

    def __init__(self) -> None:
        #: Blackboard writes of the last tick, ``[(key, value)]`` (kept while logging).
        self.writes: list[tuple[str, Any]] = []

    def start(self, values: Mapping[str, Any] | None, logging: bool) -> None:
        """Start from ``values`` only; turn the activity stream on when ``logging``."""
        # py_trees' blackboard is process-wide: a run starts from the tree's own values
        # only. Clients and key registrations made at load time are kept.
        Blackboard.storage.clear()
        for key, value in (values or {}).items():
            Blackboard.set(key if key.startswith("/") else "/" + key, value)
        if logging:
            Blackboard.enable_activity_stream(maximum_size=100_000)

    def record(self, log: RunLog, tick: int, now: float) -> None:
        """Write the writes since the last call as ``blackboard`` records at ``tick``."""
        stream = Blackboard.activity_stream
        if self.writes:
            self.writes = []
        if stream is not None and stream.data:
            writes = self.writes
            for item in stream.data:
                if item.activity_type in LOGGED_ACTIVITIES:
                    writes.append((item.key, item.current_value))
                    log.write(
                        {
                            "kind": "blackboard",
                            "tick": tick,
                            "t": now,
                            "key": item.key,
                            "op": item.activity_type,
                            "client": item.client_name,
                            "value": jsonable(item.current_value),
                        }
                    )
            stream.clear()

    def stop(self, logging: bool) -> None:
        """Turn the activity stream off (when the run was logged)."""
        if Blackboard.activity_stream is not None and logging:
            Blackboard.disable_activity_stream()
