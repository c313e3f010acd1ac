"""Per-servo calibration: from a servo's counts to its joint's angle, and back.

LeRobot's calibration keeps, per motor, ``id``, ``drive_mode``, ``homing_offset``,
``range_min`` and ``range_max``; armtree keeps the same five, so one file reads
like the other. The homing offset lives in the servo (its Homing_Offset register):
it shifts the present position so that the joint's zero (the URDF's zero pose) is
the middle of the turn, 2048 counts, and the joint's range never crosses the
encoder's wrap from 4095 to 0. Then

    angle = direction * (present - 2048) * 360 / 4096   (degrees)

with ``direction`` -1 for ``drive_mode`` 1 (the servo counts against the joint).
``range_min`` and ``range_max`` are the present positions the joint reached when
it was moved through its range by hand; the arm is kept inside them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from armtree.errors import ConfigError
from armtree.errors import shown as _shown

from .tables import COUNTS_PER_TURN

#: The present position of every joint's zero once its homing offset is written.
MIDDLE = COUNTS_PER_TURN // 2
#: Counts per degree.
COUNTS_PER_DEG = COUNTS_PER_TURN / 360.0
#: The keys of one servo's calibration.
KEYS = ("id", "drive_mode", "homing_offset", "range_min", "range_max")


@dataclass(frozen=True)
class ServoCalibration:
    """One servo's calibration (counts; see the module docstring)."""

    id: int
    drive_mode: int = 0
    homing_offset: int = 0
    range_min: int = 0
    range_max: int = COUNTS_PER_TURN - 1

    @property
    def direction(self) -> int:
        """+1, or -1 when the servo counts against its joint."""
        return -1 if self.drive_mode else 1

    def degrees(self, present: float | np.ndarray) -> float | np.ndarray:
        """The joint angle (deg) at a present position (counts)."""
        return self.direction * (np.asarray(present, dtype=float) - MIDDLE) / COUNTS_PER_DEG

    def counts(self, degrees: float | np.ndarray) -> float | np.ndarray:
        """The present position (counts, not rounded) that puts the joint at ``degrees``."""
        return MIDDLE + self.direction * np.asarray(degrees, dtype=float) * COUNTS_PER_DEG

    def limits(self) -> tuple[float, float]:
        """The joint angles (deg) ``range_min`` and ``range_max`` allow, low first."""
        a, b = float(self.degrees(self.range_min)), float(self.degrees(self.range_max))
        return min(a, b), max(a, b)

    def as_dict(self) -> dict[str, int]:
        """The five numbers, for a calibration file."""
        return {k: int(getattr(self, k)) for k in KEYS}


def parse_calibration(value: Any, where: str) -> ServoCalibration:
    """One joint's calibration mapping at dotted path ``where``; ConfigError names the key."""
    if not isinstance(value, Mapping):
        raise ConfigError(f"{where}: expected {{{', '.join(KEYS)}}}, got {_shown(value)}")
    unknown = sorted(set(value) - set(KEYS))
    if unknown:
        raise ConfigError(f"{where}.{unknown[0]}: unknown key (known: {', '.join(KEYS)})")
    if "id" not in value:
        raise ConfigError(f"{where}: needs the servo's id")
    numbers = {}
    for key in KEYS:
        v = value.get(key, getattr(ServoCalibration, key, None))
        if isinstance(v, bool) or not isinstance(v, int):
            raise ConfigError(f"{where}.{key}: expected a whole number, got {_shown(v)}")
        numbers[key] = v
    if numbers["drive_mode"] not in (0, 1):
        raise ConfigError(f"{where}.drive_mode: 0 (with the joint) or 1 (against it)")
    lo, hi = numbers["range_min"], numbers["range_max"]
    if not 0 <= lo < hi <= COUNTS_PER_TURN - 1:
        raise ConfigError(
            f"{where}.range_min: expected 0 <= range_min < range_max <= {COUNTS_PER_TURN - 1}, "
            f"got {lo} and {hi}"
        )
    return ServoCalibration(**numbers)


def calibration_file_text(entries: Mapping[str, ServoCalibration], arm: str) -> str:
    """A calibration file a profile includes (``include: FILE``): ``arm: {calibration: ...}``."""
    lines = [
        f"# Servo calibration of the {arm} arm, written by 'armtree calibrate servos'.",
        "# Per joint (LeRobot's five numbers): the servo's id, drive_mode (1: it counts",
        "# against the joint), homing_offset (written into the servo: the joint's zero",
        "# reads 2048) and the range of present positions it was moved through (counts,",
        "# 4096 a turn). A profile uses it with `include: THIS_FILE`.",
        "arm:",
        "  calibration:",
    ]
    for joint, c in entries.items():
        body = ", ".join(f"{k}: {v}" for k, v in c.as_dict().items())
        lines.append(f"    {joint}: {{{body}}}")
    return "\n".join(lines) + "\n"
