"""Marlin G-code line format and replies (Marlin 2.0.x: queue.cpp, language.h).

Host lines are ``N<n> <command>*<cs>`` with ``cs`` the XOR of every byte before
``*`` ([MARLIN queue.cpp]). Replies are text lines: ``ok``, ``Error:...``,
``Resend: <n>``, ``echo:...``, the M114 position line and the M119 end-stop
report. The VICRA arm uses Marlin as a plain joint controller: the X axis is
the shoulder (theta1, degrees), Y the elbow (theta2, degrees), Z the column
(mm); the wrist and gripper are servos 0 and 1 (M280).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field


def checksum(text: str) -> int:
    """XOR of every byte of ``text`` (the part of a line before ``*``)."""
    cs = 0
    for b in text.encode("ascii", "replace"):
        cs ^= b
    return cs


def numbered(n: int, command: str) -> str:
    """``N<n> <command>*<cs>`` without the newline; ``numbered(1, 'G28') == 'N1 G28*18'``."""
    body = f"N{n} {command}"
    return f"{body}*{checksum(body)}"


@dataclass(frozen=True)
class HostLine:
    """A line as the firmware reads it: optional number, command text, checksum status.

    ``problem`` is None for a good line, else ``"checksum"`` (mismatch) or
    ``"no_checksum"`` (a numbered line without ``*``).
    """

    number: int | None
    command: str
    problem: str | None = None


_N_RE = re.compile(r"^N(-?\d+)\s*")


def parse_host_line(raw: str) -> HostLine:
    """Split a received line into number, command and checksum verdict ([MARLIN queue.cpp])."""
    line = raw.strip()
    semi = line.find(";")
    if semi >= 0:
        line = line[:semi].rstrip()
    m = _N_RE.match(line)
    if not m:
        star = line.find("*")
        return HostLine(None, (line[:star] if star >= 0 else line).strip())
    number = int(m.group(1))
    star = line.find("*")
    if star < 0:
        return HostLine(number, line[m.end() :].strip(), "no_checksum")
    body, cs_text = line[:star], line[star + 1 :].strip()
    command = body[m.end() :].strip()
    if not cs_text.isdigit() or int(cs_text) != checksum(body):
        return HostLine(number, command, "checksum")
    return HostLine(number, command)


def words(command: str) -> tuple[str, dict[str, float]]:
    """The command code (``"G1"``, ``"M280"``) and its numeric words (``{"X": 10.0}``).

    Words whose value does not parse are left out, as Marlin reads them as 0
    only when present; callers check what they need.
    """
    parts = command.split()
    if not parts:
        return "", {}
    code = parts[0].upper()
    if len(code) > 1 and code[0] in "GMT" and code[1:].replace(".", "", 1).isdigit():
        code = code[0] + str(int(float(code[1:])))
    args: dict[str, float] = {}
    for p in parts[1:]:
        if len(p) >= 1 and p[0].isalpha():
            try:
                args[p[0].upper()] = float(p[1:]) if len(p) > 1 else 0.0
            except ValueError:
                continue
    return code, args


# --------------------------------------------------------------------------- replies


@dataclass(frozen=True)
class Position:
    """An M114 report: axis positions (deg / mm) and stepper counts."""

    axes: dict[str, float]
    counts: dict[str, int] = field(default_factory=dict)


_AXIS_RE = re.compile(r"([XYZE]):\s*(-?\d+(?:\.\d+)?)")
_COUNT_RE = re.compile(r"([XYZABC]):\s*(-?\d+)")


def parse_m114(line: str) -> Position | None:
    """Parse ``X:0.00 Y:0.00 Z:0.00 E:0.00 Count X:0 Y:0 Z:0``; None if it is not one."""
    head, _, tail = line.partition("Count")
    axes = {k: float(v) for k, v in _AXIS_RE.findall(head)}
    if not {"X", "Y", "Z"} <= axes.keys():
        return None
    counts = {k: int(v) for k, v in _COUNT_RE.findall(tail)}
    return Position(axes, counts)


def format_m114(x: float, y: float, z: float, counts: tuple[int, int, int]) -> str:
    """The M114 line as Marlin prints it (two decimals, then the stepper counts)."""
    return f"X:{x:.2f} Y:{y:.2f} Z:{z:.2f} E:0.00 Count X:{counts[0]} Y:{counts[1]} Z:{counts[2]}"


_ENDSTOP_RE = re.compile(r"^([xyz]_(?:min|max)):\s*(open|TRIGGERED)\s*$")


def parse_endstop(line: str) -> tuple[str, bool] | None:
    """``('x_min', True)`` for ``x_min: TRIGGERED``; None for other lines."""
    m = _ENDSTOP_RE.match(line.strip())
    if not m:
        return None
    return m.group(1), m.group(2) == "TRIGGERED"


_RESEND_RE = re.compile(r"^(?:Resend|rs)[: ]\s*N?(\d+)", re.IGNORECASE)


def parse_resend(line: str) -> int | None:
    """The line number asked for by ``Resend: <n>`` (or ``rs N<n>``), else None."""
    m = _RESEND_RE.match(line.strip())
    return int(m.group(1)) if m else None


def is_ok(line: str) -> bool:
    """True for ``ok`` and ADVANCED_OK's ``ok N.. P.. B..``."""
    s = line.strip()
    return s == "ok" or s.startswith("ok ")
