"""Taps on the rig: the frames, detections and plans the skills got, as they got them.

A tap wraps one method of one component instance (``camera.read``,
``tracker.detect``, ``planner.plan``) so the monitor shows exactly what the
tree saw, for any camera, tracker or planner plugin, without a hook in each.
The wrapper only keeps a reference to the result; :meth:`RigTaps.remove`
puts the original methods back.
"""

from __future__ import annotations

import contextlib
import functools
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from armtree.api.rig import Detection, Frame, Rig


@dataclass(frozen=True)
class Seen:
    """The newest frame a skill read, and the detections found in it (``None``: not looked).

    ``seq`` grows with every new frame and every detection, so a reader can tell
    whether anything changed since it last looked.
    """

    frame: Frame
    detections: list[Detection] | None
    seq: int


class RigTaps:
    """Keeps the newest camera frame, its detections and the newest planned path."""

    def __init__(self, rig: Rig) -> None:
        self.rig = rig
        self._lock = threading.Lock()
        self._seen: Seen | None = None
        self._searched: Seen | None = None
        self._seq = 0
        #: Joint waypoints (N, dof) of the newest plan, degrees / mm.
        self.plan: np.ndarray | None = None
        self.plan_seq = 0
        self._wrapped: list[tuple[Any, str]] = []
        camera = getattr(rig, "camera", None)
        tracker = getattr(rig, "tracker", None)
        planner = getattr(rig, "planner", None)
        if camera is not None:
            self._wrap(camera, "read", self._on_frame)
        if tracker is not None:
            self._wrap(tracker, "detect", self._on_detect)
        if planner is not None:
            self._wrap(planner, "plan", self._on_plan)

    @property
    def seen(self) -> Seen | None:
        """The newest frame and its detections."""
        return self._seen

    def shown(self, within_s: float = 0.5) -> Seen | None:
        """What to show: the newest frame, or the newest searched one when the newest was
        not searched and the searched one is at most ``within_s`` (run seconds) older."""
        seen, searched = self._seen, self._searched
        if (
            seen is not None
            and seen.detections is None
            and searched is not None
            and seen.frame.timestamp - searched.frame.timestamp <= within_s
        ):
            return searched
        return seen

    def _wrap(self, component: Any, name: str, after: Callable[..., None]) -> None:
        original = getattr(component, name)

        @functools.wraps(original)
        def tapped(*args: Any, **kwargs: Any) -> Any:
            result = original(*args, **kwargs)
            # A monitor must never break a skill.
            with contextlib.suppress(Exception):
                after(result, *args)
            return result

        setattr(component, name, tapped)
        self._wrapped.append((component, name))

    def _on_frame(self, frame: Frame | None) -> None:
        if frame is None:
            return
        with self._lock:
            self._seq += 1
            self._seen = Seen(frame, None, self._seq)

    def _on_detect(self, detections: list[Detection], frame: Frame, *_: Any) -> None:
        # A new sequence number either way: the frame now comes with what was found in it.
        with self._lock:
            self._seq += 1
            self._seen = self._searched = Seen(frame, list(detections), self._seq)

    def _on_plan(self, path: Any, *_: Any) -> None:
        q = np.asarray(path, dtype=float)
        if q.ndim == 2 and len(q) >= 2:
            self.plan = q
            self.plan_seq += 1

    def remove(self) -> None:
        """Put the original methods back (idempotent)."""
        while self._wrapped:
            component, name = self._wrapped.pop()
            if name in vars(component):
                delattr(component, name)


__all__ = ["RigTaps", "Seen"]
