"""Low-pass smoothing of marker poses, one estimate per marker id.

Showers 2016, appendix D: the tracking behaviour keeps an estimate of the marker
position and blends each new measurement in with weight ``alpha = 0.2``
(``P_est = alpha * P + (1 - alpha) * P_est``), so a faulty reading moves the
arm by a fifth of its error at most. The estimate starts from the first
measurement and is dropped when the marker is lost, so a marker that comes
back is not pulled towards where it used to be.

Skills use this module (it is plugin-free); units are millimetres for
translations and radians for rotation vectors (OpenCV's Rodrigues form).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

#: Weight of a new measurement, Showers 2016 appendix D.
DEFAULT_ALPHA = 0.2


@dataclass
class SmoothedPose:
    """The filtered pose of one marker.

    ``tvec`` in mm and ``rvec`` (radians, None when no rotation was measured) in
    the camera frame; ``timestamp`` of the newest measurement (s); ``samples``
    counts measurements since the estimate was (re)started; ``missed`` counts
    consecutive frames without the marker.
    """

    marker_id: int
    tvec: np.ndarray
    rvec: np.ndarray | None
    timestamp: float
    samples: int = 1
    missed: int = 0


class PoseFilter:
    """Exponential low-pass filter of marker poses per marker id (Showers 2016, appendix D).

    ``alpha`` is the weight of a new measurement (0 < alpha <= 1; 1 disables
    smoothing). A marker missing from more than ``max_missed`` consecutive
    frames given to :meth:`update_frame` is lost and its estimate reset.
    Rotations are blended on unit quaternions (normalised linear blend, the
    short way round), which equals the same low-pass on small changes.
    """

    def __init__(self, alpha: float = DEFAULT_ALPHA, max_missed: int = 0) -> None:
        if not 0.0 < alpha <= 1.0:
            raise ValueError(f"alpha must be in (0, 1], got {alpha}")
        if max_missed < 0:
            raise ValueError(f"max_missed must be >= 0, got {max_missed}")
        self.alpha = float(alpha)
        self.max_missed = int(max_missed)
        self._poses: dict[int, SmoothedPose] = {}
        self._quats: dict[int, np.ndarray] = {}

    def __contains__(self, marker_id: int) -> bool:
        return marker_id in self._poses

    def get(self, marker_id: int) -> SmoothedPose | None:
        """The current estimate for ``marker_id``, or None when it is not tracked."""
        return self._poses.get(marker_id)

    def update(
        self,
        marker_id: int,
        tvec: np.ndarray,
        rvec: np.ndarray | None = None,
        timestamp: float = 0.0,
    ) -> SmoothedPose:
        """Blend one measurement (``tvec`` mm, ``rvec`` radians) into the estimate.

        The first measurement of a marker (or the first after a reset) becomes
        the estimate as it is; later ones move it by ``alpha`` of the difference.
        """
        t = np.asarray(tvec, dtype=float).reshape(3)
        q_new = None
        if rvec is not None:
            # SciPy's rotations take a third of a second to import: a filter of positions
            # alone (the Track skill's) never loads them.
            from scipy.spatial.transform import Rotation

            q_new = Rotation.from_rotvec(np.reshape(rvec, 3)).as_quat()
        old = self._poses.get(marker_id)
        if old is None:
            self._quats.pop(marker_id, None)
            if q_new is not None:
                self._quats[marker_id] = q_new
            pose = SmoothedPose(marker_id, t.copy(), _rotvec(q_new), float(timestamp))
            self._poses[marker_id] = pose
            return pose
        # Showers 2016, appendix D: P_est = alpha * P + (1 - alpha) * P_est
        old.tvec = self.alpha * t + (1.0 - self.alpha) * old.tvec
        if q_new is not None:
            q_old = self._quats.get(marker_id)
            if q_old is None:
                q = q_new
            else:
                if float(np.dot(q_old, q_new)) < 0.0:
                    q_new = -q_new
                q = self.alpha * q_new + (1.0 - self.alpha) * q_old
                q /= np.linalg.norm(q)
            self._quats[marker_id] = q
            old.rvec = _rotvec(q)
        old.timestamp = float(timestamp)
        old.samples += 1
        old.missed = 0
        return old

    def update_frame(self, detections: Iterable, timestamp: float = 0.0) -> dict[int, SmoothedPose]:
        """Feed every detection of one frame; markers not in it count as missed.

        ``detections`` are :class:`armtree.api.rig.Detection` objects (or anything
        with ``id``, ``tvec`` and ``rvec``); ones without a pose are treated as
        not seen. Returns the estimates of the markers still tracked.
        """
        seen: set[int] = set()
        for det in detections:
            if getattr(det, "tvec", None) is None:
                continue
            self.update(int(det.id), det.tvec, getattr(det, "rvec", None), timestamp)
            seen.add(int(det.id))
        for marker_id in list(self._poses):
            if marker_id in seen:
                continue
            pose = self._poses[marker_id]
            pose.missed += 1
            if pose.missed > self.max_missed:
                self.reset(marker_id)
        return dict(self._poses)

    def reset(self, marker_id: int | None = None) -> None:
        """Forget one marker's estimate (it was lost), or every estimate when None."""
        if marker_id is None:
            self._poses.clear()
            self._quats.clear()
        else:
            self._poses.pop(marker_id, None)
            self._quats.pop(marker_id, None)


def _rotvec(q: np.ndarray | None) -> np.ndarray | None:
    if q is None:
        return None
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(q).as_rotvec()
