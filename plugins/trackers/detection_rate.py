"""Marker detection rate, Showers 2016 eq. 15: detections per frame times the camera frame rate.

The Dobot report recorded 200 frames at 20 fps and counted how often one
marker was found: 18.91 markers/s for a stationary marker and 9.79 for a
moving one with moving shadows, raised to 19.99 and 14.10 by preprocessing
(grey, threshold at 40 %, slight blur). A perfect tracker scores the frame rate.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from armtree.api.rig import Frame, Tracker


@dataclass(frozen=True)
class DetectionRate:
    """Frames looked at, markers found in them, and the camera frame rate (Hz)."""

    frames: int
    detections: int
    fps: float

    @property
    def per_frame(self) -> float:
        """Markers found per frame (1.0 for one marker found in every frame)."""
        return self.detections / self.frames if self.frames else 0.0

    @property
    def rate(self) -> float:
        """Showers 2016 eq. 15: MDR = (# markers detected / # frames taken) * frame rate, markers/s."""
        return self.per_frame * self.fps


def marker_detection_rate(
    tracker: Tracker, frames: Iterable[Frame], fps: float, marker_id: int | None = None
) -> DetectionRate:
    """Run ``tracker`` over ``frames`` and count detections (of ``marker_id``, or of any marker).

    ``fps`` is the rate the frames were taken at (Hz); it must be positive.
    """
    if not fps > 0:
        raise ValueError(f"the frame rate must be positive, got {fps}")
    n_frames = 0
    found = 0
    for frame in frames:
        n_frames += 1
        found += sum(1 for d in tracker.detect(frame) if marker_id is None or d.id == marker_id)
    return DetectionRate(n_frames, found, float(fps))
