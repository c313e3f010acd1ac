"""Doubting what an arm says: a decoded status is believed only when it is plausible.

Serial frames can be damaged on the way (the Dobot V1.0's carry no checksum at
all), and a device that is not the arm can send anything. A :class:`StatusGuard`
checks every decoded joint reading before a driver believes it:

* every value finite;
* within the model's joint limits plus a margin (:data:`LIMIT_MARGIN`);
* no jump faster than the arm can move: at most ``max_speed`` times the time since
  the last believed reading (times :data:`SPEED_SLACK`) plus :data:`JUMP_SLACK`.

Readings that fail are counted as corrupt, as are bytes the frame parser had to
skip (one frame's worth of skipped bytes counts as one corrupt frame). The link
is lost when most of the recent frames are corrupt (:meth:`StatusGuard.verdict`);
the driver's link timeout counts only believed readings, so noise cannot keep a
dead link alive. A connection needs :data:`STABLE_FRAMES` plausible readings in a
row that agree with each other (:attr:`StatusGuard.stable`). Units: degrees (mm
for prismatic joints) and seconds on the run's clock.
"""

from __future__ import annotations

import collections
import math
from collections.abc import Sequence

import numpy as np

from armtree.maths.motion.kinematics import KinematicModel

#: How far outside its limits a reported joint may be before it is not believed
#: (degrees, or mm for a prismatic joint): encoders and calibration drift a little.
LIMIT_MARGIN = 10.0
#: Factor on the joints' top speeds for what two readings may differ by.
SPEED_SLACK = 2.0
#: Difference always allowed between two readings (degrees / mm): quantisation, jitter.
JUMP_SLACK = 2.0
#: Plausible readings in a row a connection needs before the arm's state is known.
STABLE_FRAMES = 3
#: Seconds after a pause of the process in which readings re-base rather than jump: what
#: was sent before and during the pause arrives first.
RESYNC_S = 0.25
#: Recent frames the corrupt fraction is judged over.
WINDOW = 40
#: Fraction of corrupt frames in the window above which the link is lost.
MAX_CORRUPT = 0.5


class StatusGuard:
    """Plausibility of one arm's joint readings and the link's corruption; see the module."""

    def __init__(self, model: KinematicModel, *, frame_bytes: int = 0) -> None:
        self.model = model
        self.lower = np.asarray(model.lower, dtype=float) - LIMIT_MARGIN
        self.upper = np.asarray(model.upper, dtype=float) + LIMIT_MARGIN
        self.max_speed = np.array([j.max_speed for j in model.joints], dtype=float)
        self._lower, self._upper, self._top = (
            self.lower.tolist(),
            self.upper.tolist(),
            self.max_speed.tolist(),
        )
        self.names = [j.name for j in model.joints]
        #: Bytes of one frame, to count skipped bytes as frames (0: do not count them).
        self.frame_bytes = frame_bytes
        #: Plausible readings believed, and implausible ones refused, since the start.
        self.believed = 0
        self.corrupt = 0
        #: Why the newest refused reading was refused.
        self.last_reason = ""
        self._recent: collections.deque[bool] = collections.deque(maxlen=WINDOW)
        self._last: np.ndarray | None = None
        self._last_t = -math.inf
        self._streak = 0
        self._skipped = 0
        self._resync_until = -math.inf

    def reset(self) -> None:
        """Forget everything (a new connection)."""
        self.__init__(self.model, frame_bytes=self.frame_bytes)  # type: ignore[misc]

    # ------------------------------------------------------------------ readings

    def check(self, q: Sequence[float] | np.ndarray, now: float) -> str | None:
        """``None`` when ``q`` (one joint reading at run time ``now``) is plausible, else why.

        A plausible reading becomes the reference for the next; a refused one is
        counted as corrupt.
        """
        reason = self._reason(np.asarray(q, dtype=float), now)
        if reason is None:
            self._last = np.asarray(q, dtype=float)
            self._last_t = now
            self.believed += 1
            self._streak += 1
            self._recent.append(True)
        else:
            self.corrupt += 1
            self.last_reason = reason
            self._streak = 0
            self._recent.append(False)
        return reason

    def resync(self, now: float) -> None:
        """The process was paused while the arm went on (see the serial driver): the
        readings of the next :data:`RESYNC_S` seconds are judged without the jump check
        (each the new reference, the newest being where the arm is), the corrupt window
        is forgotten, and :attr:`stable` needs its streak again."""
        self.rebase()
        self._resync_until = now + RESYNC_S
        self._recent.clear()
        self._streak = 0
        self._skipped = 0

    def rebase(self) -> None:
        """Forget the last believed reading (homing redefined the coordinates); keep counts."""
        self._last = None
        self._last_t = -math.inf

    def skipped(self, count: int) -> None:
        """The frame parser skipped ``count`` more bytes (damage or noise between frames)."""
        if self.frame_bytes <= 0 or count <= 0:
            return
        self._skipped += count
        while self._skipped >= self.frame_bytes:
            self._skipped -= self.frame_bytes
            self.corrupt += 1
            self._streak = 0
            self._recent.append(False)

    def refused(self, reason: str) -> None:
        """A frame or reply that failed the protocol's own checks (count it as corrupt)."""
        self.corrupt += 1
        self.last_reason = reason
        self._streak = 0
        self._recent.append(False)

    @property
    def stable(self) -> bool:
        """True once :data:`STABLE_FRAMES` plausible readings came in a row."""
        return self._streak >= STABLE_FRAMES

    def verdict(self) -> str | None:
        """Why the link must be considered lost (mostly corrupt frames), or ``None``."""
        recent = self._recent
        if len(recent) < WINDOW // 2:
            return None
        bad = len(recent) - sum(recent)
        if bad > MAX_CORRUPT * len(recent):
            why = f"; the last refused: {self.last_reason}" if self.last_reason else ""
            return f"{bad} of the last {len(recent)} frames were corrupt or implausible{why}"
        return None

    def _reason(self, q: np.ndarray, now: float) -> str | None:
        if q.shape != self.lower.shape:
            return f"{q.size} joint values for a {self.lower.size}-joint arm"
        # Plain floats: for the few joints of one reading, numpy's per-call cost is most of it.
        values = q.tolist()
        if not all(map(math.isfinite, values)):
            return f"a joint reading is not a finite number ({_fmt(q)})"
        for k, (v, lo, hi) in enumerate(zip(values, self._lower, self._upper, strict=True)):
            if v < lo or v > hi:
                return (
                    f"{self.names[k]} = {q[k]:.4g} is outside its limits "
                    f"[{self.lower[k] + LIMIT_MARGIN:g}, {self.upper[k] - LIMIT_MARGIN:g}] "
                    f"by more than {LIMIT_MARGIN:g}"
                )
        if self._last is not None and now >= self._resync_until:
            dt = max(0.0, now - self._last_t) if math.isfinite(self._last_t) else math.inf
            for k, (v, last, top) in enumerate(
                zip(values, self._last.tolist(), self._top, strict=True)
            ):
                jump = abs(v - last)
                if jump > top * SPEED_SLACK * dt + JUMP_SLACK:
                    return (
                        f"{self.names[k]} jumped {jump:.4g} in {dt:.3g} s, faster than the "
                        f"arm moves ({self.max_speed[k]:g}/s)"
                    )
        return None


def _fmt(q: np.ndarray) -> str:
    return ", ".join(f"{v:.4g}" for v in q.tolist())
