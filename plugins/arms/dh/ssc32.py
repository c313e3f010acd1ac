"""Lynxmotion SSC-32 servo controller protocol and the pulse-to-angle map of each joint.

Aceves slides ("Servomotores", "SSC-32 Servo Controller") drives each joint of a
hobby arm with a servo whose pulse width maps linearly to the joint angle,
``q_i = f_i(x) = m_i x + b_i``, fitted by least squares from a table of
measured (pulse, angle) pairs (Aceves slides, "ajuste de curva (Ej. Mínimos
cuadrados)"). The slides' own example: 0.3 ms -> 170 deg, 1.2 ms -> 85 deg,
2.1 ms -> 0 deg.

SSC-32 ASCII commands (Lynxmotion SSC-32 manual), each ended by a carriage return:

* ``#<ch>P<pulse>[S<speed>]...[T<ms>]`` move one or more channels (a group move
  ends on every channel at the same time, ``T`` ms after it starts);
* ``Q`` -> ``+`` while a move is in progress, ``.`` when complete;
* ``QP<ch>`` -> one byte, the channel's pulse width / 10 (``150`` = 1500 us);
* ``STOP<ch>`` stops a channel where it is; ``VER`` -> the firmware version.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from armtree.errors import ConfigError

#: Pulse widths the SSC-32 accepts, microseconds.
PULSE_MIN, PULSE_MAX = 500, 2500
VERSION = "SSC32-V2.50USB"


@dataclass(frozen=True)
class ServoMap:
    """Joint ``q = slope * pulse + intercept`` (deg or mm; pulse in microseconds) on ``channel``."""

    channel: int
    slope: float
    intercept: float
    residual: float = 0.0

    @classmethod
    def fit(cls, channel: int, table: Sequence[Sequence[float]]) -> ServoMap:
        """Least-squares line through ``[[pulse_us, angle], ...]`` (Aceves slides, servo mapping).

        ``residual`` is the RMS error of the fit in joint units.
        """
        data = np.asarray(table, dtype=float)
        if data.ndim != 2 or data.shape[1] != 2 or len(data) < 2:
            raise ValueError("a servo table needs at least two [pulse_us, angle] pairs")
        if np.ptp(data[:, 0]) <= 0:
            raise ValueError("a servo table needs at least two different pulse widths")
        A = np.column_stack([data[:, 0], np.ones(len(data))])
        (m, b), *_ = np.linalg.lstsq(A, data[:, 1], rcond=None)
        rms = float(np.sqrt(np.mean((A @ (m, b) - data[:, 1]) ** 2)))
        return cls(int(channel), float(m), float(b), rms)

    def angle(self, pulse: np.ndarray | float) -> np.ndarray:
        """Joint value for a pulse width (us)."""
        return self.slope * np.asarray(pulse, dtype=float) + self.intercept

    def pulse(self, angle: np.ndarray | float) -> np.ndarray:
        """Pulse width (us, not rounded) that puts the joint at ``angle``."""
        return (np.asarray(angle, dtype=float) - self.intercept) / self.slope

    def range(self) -> tuple[float, float]:
        """The joint values reachable with pulses in [500, 2500] us, (low, high)."""
        a, b = float(self.angle(PULSE_MIN)), float(self.angle(PULSE_MAX))
        return (min(a, b), max(a, b))


class JointServos:
    """The joint servos' maps as arrays: one expression converts every joint at once.

    The same arithmetic as :meth:`ServoMap.angle` and :meth:`ServoMap.pulse`, joint by joint.
    """

    def __init__(self, maps: Sequence[ServoMap]) -> None:
        self.channels = np.array([m.channel for m in maps], dtype=int)
        self.slopes = np.array([m.slope for m in maps], dtype=float)
        self.intercepts = np.array([m.intercept for m in maps], dtype=float)

    def angles(self, pulses: np.ndarray) -> np.ndarray:
        """Joint values for the joints' pulse widths ``pulses`` (us), one per joint."""
        return self.slopes * pulses + self.intercepts

    def pulses(self, angles: np.ndarray) -> np.ndarray:
        """Pulse widths (us, not rounded) that put the joints at ``angles``."""
        return (np.asarray(angles, dtype=float) - self.intercepts) / self.slopes


def servo_maps_from_config(config: Any, n_joints: int, source: str = "<profile>") -> list[ServoMap]:
    """Maps from a profile's ``arm.servos`` list (one ``{channel, table}`` per joint).

    Without it, joint ``i`` is on channel ``i`` with a standard 180-degree
    servo: 1500 us at 0, 0.09 degrees per microsecond.
    """
    if config is None:
        return [ServoMap(i, 0.09, -135.0) for i in range(n_joints)]
    if not isinstance(config, Sequence) or isinstance(config, str) or len(config) != n_joints:
        raise ConfigError(f"arm.servos must list one servo per joint ({n_joints})", source)
    maps = []
    for i, item in enumerate(config):
        if not isinstance(item, Mapping) or "table" not in item:
            raise ConfigError(f"arm.servos[{i}] needs a table of [pulse_us, angle] pairs", source)
        ch = item.get("channel", i)
        if isinstance(ch, bool) or not isinstance(ch, int) or not 0 <= ch <= 31:
            raise ConfigError(f"arm.servos[{i}].channel must be 0-31, got {ch!r}", source)
        try:
            maps.append(ServoMap.fit(ch, item["table"]))
        except (ValueError, TypeError) as exc:
            raise ConfigError(f"arm.servos[{i}].table: {exc}", source) from exc
    if len({m.channel for m in maps}) != len(maps):
        raise ConfigError("arm.servos: two joints share a channel", source)
    return maps


# --------------------------------------------------------------------------- commands


def move_command(pulses: Mapping[int, int], time_ms: int | None = None) -> bytes:
    """A group move: ``#0P1500#1P1600T1000\\r``. Pulses must be in [500, 2500]."""
    parts = []
    for ch, p in sorted(pulses.items()):
        if not PULSE_MIN <= p <= PULSE_MAX:
            raise ValueError(f"pulse {p} us on channel {ch} is outside {PULSE_MIN}-{PULSE_MAX}")
        parts.append(f"#{ch}P{int(p)}")
    if time_ms is not None:
        parts.append(f"T{int(time_ms)}")
    return ("".join(parts) + "\r").encode("ascii")


def query_pulses(channels: Sequence[int]) -> bytes:
    """``QP0 QP1 ...\\r``: the board answers one byte per channel."""
    return (" ".join(f"QP{c}" for c in channels) + "\r").encode("ascii")


QUERY_MOTION = b"Q\r"


def stop_command(channels: Sequence[int]) -> bytes:
    """``STOP0 STOP1 ...\\r``: every channel stops where it is."""
    return (" ".join(f"STOP{c}" for c in channels) + "\r").encode("ascii")


@dataclass(frozen=True)
class Request:
    """One parsed command line: group moves, queries and stops, in order of appearance."""

    moves: dict[int, tuple[int, float | None]]
    time_ms: float | None
    queries: tuple[tuple[str, int | None], ...]
    stops: tuple[int, ...]
    version: bool = False
    errors: int = 0


_TOKEN = re.compile(
    r"#(\d+)|P(\d+)|S(\d+)|T(\d+)|QP\s*(\d+)|Q|STOP\s*(\d+)|VER|(\S)", re.IGNORECASE
)


def parse_request(line: str) -> Request:
    """Parse a command line as the SSC-32 does; unknown characters are counted and skipped."""
    moves: dict[int, tuple[int, float | None]] = {}
    queries: list[tuple[str, int | None]] = []
    stops: list[int] = []
    time_ms: float | None = None
    version = False
    errors = 0
    channel: int | None = None
    for m in _TOKEN.finditer(line.upper()):
        ch, pulse, speed, tms, qp, stop, junk = m.groups()
        text = m.group(0)
        if ch is not None:
            channel = int(ch)
        elif pulse is not None and channel is not None:
            moves[channel] = (int(pulse), None)
        elif speed is not None and channel is not None and channel in moves:
            moves[channel] = (moves[channel][0], float(speed))
        elif tms is not None:
            time_ms = float(tms)
        elif qp is not None:
            queries.append(("QP", int(qp)))
        elif stop is not None:
            stops.append(int(stop))
        elif text == "Q":
            queries.append(("Q", None))
        elif text == "VER":
            version = True
        elif junk is not None or text:
            errors += 1
    return Request(moves, time_ms, tuple(queries), tuple(stops), version, errors)
