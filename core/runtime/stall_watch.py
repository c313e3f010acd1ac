"""A run that makes no progress is reported as a stall, not left to spin in silence.

After every tick :class:`StallWatch` asks whether anything moved on: a node's
status changed, the blackboard was written (seen while the run is logged), a
node's ``feedback_message`` changed, or the arm's joints moved more than
:data:`MOTION_TOL` (degrees or mm) since the quiet began. When none of these
happened for the profile's ``watchdog: {stall_s: S}`` seconds of run time
(:data:`DEFAULT_STALL_S` by default, far above any quiet stretch of a shipped
tree), the stall is reported once, as a ``stall`` event in the run log and a line
in the live view and the summary; it is reported again only after some progress.
A stall does not end the run: a behaviour may wait that long on purpose. The run
ends at its ``--timeout`` (run-tree gives simulated runs one by default), and the
timeout's message then says since when nothing moved.
"""

from __future__ import annotations

from collections.abc import Sequence
from operator import attrgetter
from typing import Any

import numpy as np

from armtree.api.views import ProfileView
from armtree.config.profile_sections import DEFAULT_STALL_S

#: Joint travel (degrees or mm) since the quiet began that counts as motion; below
#: it, a real arm's reading jitter.
MOTION_TOL = 0.05

_FEEDBACK = attrgetter("feedback_message")


class StallWatch:
    """Whether one run's tree still makes progress; see the module docstring.

    :meth:`start` takes the tree's nodes and the rig's arm (None: no motion
    seen); :meth:`observe` is called after each tick. :attr:`longest` is the
    longest quiet stretch so far (s), :attr:`quiet_since` when the present one
    began, and :attr:`stalled` whether it was reported.
    """

    def __init__(self, limit_s: float = DEFAULT_STALL_S) -> None:
        self.limit_s = float(limit_s)
        self.quiet_since = 0.0
        self.stalled = False
        self.longest = 0.0
        self._nodes: Sequence[Any] = ()
        self._arm: Any = None
        self._statuses: tuple[str, ...] | None = None
        self._feedback: list[Any] | None = None
        self._joints: np.ndarray | None = None

    def start(self, now: float, nodes: Sequence[Any], arm: Any) -> None:
        """Watch ``nodes`` (and ``arm``'s joints) from run time ``now``, as if all moved then."""
        self._nodes, self._arm = nodes, arm
        self._progress(now, None)

    def observe(self, now: float, statuses: tuple[str, ...], wrote: bool) -> bool:
        """After the tick at ``now``: True when a stall begins (report it once).

        ``statuses`` is the run's tuple of status names (a new tuple on each change),
        ``wrote`` whether the tick wrote the blackboard.
        """
        if statuses is not self._statuses or wrote or self._said() or self._moved():
            self._progress(now, statuses)
            return False
        quiet = now - self.quiet_since
        self.longest = max(self.longest, quiet)
        if self.stalled or quiet < self.limit_s - 1e-9:
            return False
        self.stalled = True
        return True

    def _progress(self, now: float, statuses: tuple[str, ...] | None) -> None:
        # What was said and where the arm was are noted at the first quiet tick, so a
        # tree whose statuses change every tick reads neither.
        self.quiet_since, self.stalled, self._statuses = now, False, statuses
        self._feedback, self._joints = None, None

    def _said(self) -> bool:
        """True when a node's feedback message changed since the quiet began."""
        feedback = list(map(_FEEDBACK, self._nodes))
        if self._feedback is None:
            self._feedback = feedback
            return False
        return feedback != self._feedback

    def _moved(self) -> bool:
        """True when the arm's joints left where they were when the quiet began."""
        if self._arm is None:
            return False
        try:
            joints = np.asarray(self._arm.joints(), dtype=float)
        except Exception:  # noqa: BLE001 - a link fault is reported by the arm, not here
            return False
        if self._joints is None or self._joints.shape != joints.shape:
            self._joints = joints
            return False
        return bool(np.max(np.abs(joints - self._joints), initial=0.0) > MOTION_TOL)


def profile_stall_limit(profile: ProfileView | None) -> float:
    """The profile's ``watchdog: {stall_s: S}``, else :data:`DEFAULT_STALL_S` (run seconds)."""
    data = getattr(profile, "data", None)
    section = data.get("watchdog") if isinstance(data, dict) else None
    value = section.get("stall_s") if isinstance(section, dict) else None
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    return DEFAULT_STALL_S


__all__ = ["MOTION_TOL", "StallWatch", "profile_stall_limit"]
