"""The uArm Swift Pro's serial dialect (firmware V4.x, Grbl-based), as text.

Host to arm: ``#<n> <CMD> <params>\\n`` with ``n`` counting 1..9999 and back to 1
(the SDK's ``'#{cnt} {msg}'``). Arm to host:

* ``$<n> ok[ <payload>]`` or ``$<n> E2x[ <payload>]``: the reply to command ``n``;
  numbers with four decimals (``$5 ok X200.0000 Y0.0000 Z150.0000``);
* ``@<k> ...``: an event (``@1`` boot done, ``@3 X Y Z R`` periodic position,
  ``@5 V1`` power, ``@6 N0 V1`` limit switch, ``@9 V0`` motion stopped);
* anything else: the boot banner (``device name : SwiftPro``), ``E23 buffer full``
  (a full queue; it carries no ``$n``), debug text.

``P`` and ``S`` commands are answered at once; ``G`` and ``M`` commands queue (20
deep) and are answered only when the arm is idle again, so the ``ok`` of a move
means the move is over. Error codes: E20 unknown command, E21 bad parameter,
E22 unreachable, E23 buffer full, E24 no power, E25 operation failed, E26
encoder, E27 motors detached. Units: mm, degrees.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: Line numbers run 1..MAX_NUMBER, then start again at 1.
MAX_NUMBER = 9999
#: What each error code means, for messages.
ERRORS = {
    "E20": "the command does not exist",
    "E21": "a parameter is wrong",
    "E22": "the position is unreachable",
    "E23": "the command buffer is full",
    "E24": "no power",
    "E25": "the operation failed",
    "E26": "the encoders do not answer",
    "E27": "the motors are detached",
}


def number(value: float) -> str:
    """A coordinate as the firmware reads it: at most four decimals, no exponent.

    The firmware copies each number into a 10-byte buffer (sscanf ``%[0-9-+.]``), so
    numbers are kept short.
    """
    text = f"{value:.4f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def command(n: int, text: str) -> str:
    """``#n text`` plus the line end."""
    return f"#{n} {text}\n"


def next_number(n: int) -> int:
    """The line number after ``n`` (1..9999, then 1 again)."""
    return 1 if n >= MAX_NUMBER else n + 1


@dataclass(frozen=True)
class Reply:
    """A ``$n`` reply: its number, ``ok`` or an error code, and the payload words."""

    number: int
    status: str
    payload: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        """True for ``ok``."""
        return self.status == "OK"

    def value(self, letter: str) -> float | None:
        """The number after ``letter`` in the payload (``V`` of ``$3 ok V1``), or None."""
        for word in self.payload:
            if word[:1].upper() == letter and len(word) > 1:
                try:
                    return float(word[1:])
                except ValueError:
                    return None
        return None

    def text(self) -> str:
        """The payload as one string (``SwiftPro``, ``V4.10.0``)."""
        return " ".join(self.payload)


_REPLY = re.compile(r"^\$(\d+)(?:\s+(\S+))?(?:\s+(.*))?$")


def parse_reply(line: str) -> Reply | None:
    """A ``$n ...`` line as a :class:`Reply` (status upper-cased, as the SDK reads it); else None.

    A Grbl error that adds no code leaves ``$n`` alone: its status is ``""``.
    """
    match = _REPLY.match(line.strip())
    if match is None:
        return None
    status = (match.group(2) or "").upper()
    payload = tuple((match.group(3) or "").split())
    return Reply(int(match.group(1)), status, payload)


def parse_event(line: str) -> tuple[int, dict[str, float]] | None:
    """``@3 X200.0000 Y0.0000 Z150.0000 R90.0000`` as ``(3, {"X": 200.0, ...})``; else None."""
    words = line.strip().split()
    if not words or not words[0].startswith("@") or not words[0][1:].isdigit():
        return None
    values = {}
    for word in words[1:]:
        try:
            values[word[0].upper()] = float(word[1:])
        except (ValueError, IndexError):
            continue
    return int(words[0][1:]), values


# --------------------------------------------------------------------------- firmware side


#: The longest line the firmware takes (longer ones get ``error: E23``).
MAX_LINE = 79


@dataclass(frozen=True)
class HostLine:
    """A line as the firmware reads it: its number (None without ``#n``) and its command."""

    number: int | None
    command: str


def read_host_line(raw: str) -> HostLine | None:
    """Clean a received line as FW4's ``protocol.c`` does; None for one it ignores.

    Comments in ``(...)`` and after ``;`` go, every byte up to space is dropped and
    letters are upper-cased; after an optional ``#digits`` the command must start
    with G, M, P or S, else the line is silently ignored.
    """
    text = re.sub(r"\([^)]*\)", "", raw).split(";")[0]
    text = "".join(ch for ch in text if ord(ch) > 0x20).upper()
    match = re.match(r"^#(\d+)(.*)$", text)
    n, body = (int(match.group(1)), match.group(2)) if match else (None, text)
    if not body or body[0] not in "GMPS":
        return None
    return HostLine(n, body)


def split_command(body: str) -> tuple[str, dict[str, float]]:
    """``G0X200Y0Z150F100`` (spaces already dropped) as ``("G0", {"X": 200, ...})``.

    A word whose number does not parse is left out; callers check what they need.
    """
    match = re.match(r"^([GMPS])(\d+)(.*)$", body)
    if match is None:
        return body, {}
    code = match.group(1) + str(int(match.group(2)))
    args: dict[str, float] = {}
    for letter, value in re.findall(r"([A-Z])([-+]?[0-9.]*)", match.group(3)):
        try:
            args[letter] = float(value)
        except ValueError:
            continue
    return code, args


def reply(n: int | None, status: str, payload: str = "") -> str:
    """The firmware's reply line: ``$n ok payload`` (``ok payload`` without a number)."""
    words = [w for w in (f"${n}" if n is not None else "", status, payload) if w]
    return " ".join(words) + "\n"


def fmt4(value: float) -> str:
    """A number as the firmware prints it (``dtostrf(v, 5, 4)``)."""
    return f"{value:.4f}"
