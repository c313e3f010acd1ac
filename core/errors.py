"""The exceptions armtree raises to users, each carrying where and how to fix it."""

from __future__ import annotations

import reprlib
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any


def did_you_mean(
    name: str, options: Iterable[str], *, cutoff: float = 0.6, list_up_to: int = 12
) -> str:
    """``"; did you mean 'x'?"`` for the closest option, else the choices when few.

    The choices are listed when there are at most ``list_up_to`` of them, and nothing is
    said otherwise (a long list helps nobody); ``cutoff`` is difflib's similarity ratio.
    """
    import difflib  # only an error message pays for it

    options = sorted(set(options))  # a place and a body may share a name
    close = difflib.get_close_matches(name, options, n=1, cutoff=cutoff)
    if close:
        return f"; did you mean {close[0]!r}?"
    if len(options) <= list_up_to:
        return f"; choose one of: {', '.join(options)}" if options else ""
    return ""


class ConfigError(ValueError):
    """Invalid input: a tree, a profile, a parameter, a plugin or a command-line value.

    Carries ``file``, ``line`` and ``column`` (1-based; ``None`` when unknown) so the
    CLI can print ``FILE:LINE:COL: message``. ``errors`` holds every problem found in
    one file when several were collected; ``str()`` of the exception lists them all.
    ``traceback`` is the text of the traceback behind a problem a plugin's code raised
    (a behaviour's constructor), which the CLI shows with ``--debug``.
    Nothing moves before a tree and its profile validate.
    """

    def __init__(
        self,
        message: str,
        file: str | None = None,
        line: int | None = None,
        column: int | None = None,
        errors: list[ConfigError] | None = None,
        *,
        traceback: str | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.column = column
        self.errors: list[ConfigError] = errors if errors else [self]
        self.traceback = traceback

    def location(self) -> str:
        """Return ``FILE:LINE:COL`` (or as much of it as is known; ``""`` for none)."""
        if self.file is None and self.line is None:
            return ""
        parts = [self.file or "<input>"]
        if self.line is not None:
            parts.append(str(self.line))
            if self.column is not None:
                parts.append(str(self.column))
        return ":".join(parts)

    def format(self) -> str:
        """Every collected error as ``FILE:LINE:COL: message``, one per line (the message
        alone when it has no position: a command-line value, a plugin's own word)."""
        return "\n".join(
            f"{e.location()}: {e.message}" if e.location() else e.message for e in self.errors
        )

    def __str__(self) -> str:
        return self.format()


class HardwareFault(RuntimeError):
    """A device failed: a missing or busy port, a lost link, a limit switch, an e-stop.

    ``device`` names the port or camera; the CLI exits 3 on it.
    """

    def __init__(self, message: str, device: str | None = None) -> None:
        super().__init__(f"{device}: {message}" if device else message)
        self.message = message
        self.device = device


class Unreachable(ValueError):
    """A Cartesian or joint target the arm cannot reach (outside limits or workspace)."""


class PlanningError(RuntimeError):
    """No collision-free path; ``reason`` says why (start in collision, disconnected, ...)."""

    def __init__(self, message: str, reason: str = "no_path") -> None:
        super().__init__(message)
        self.reason = reason


@dataclass(frozen=True)
class Mark:
    """A position in a source file, 1-based, for error messages."""

    file: str
    line: int
    column: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"


class _Shown(reprlib.Repr):
    """``repr`` bounded in length and depth, and safe for integers of any size."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlevel = 3
        self.maxlist = self.maxtuple = self.maxset = self.maxdict = 6
        self.maxstring = 60
        self.maxother = 60

    def repr_int(self, x: int, level: int) -> str:
        # Python refuses to print integers above 4,300 digits; say how long it is instead.
        digits = x.bit_length() * 0.30103
        return repr(x) if digits < 30 else f"<an integer of about {digits:.0f} digits>"


_SHOWN = _Shown()


def yaml_kind(value: Any) -> str:
    """What ``value`` is in a YAML file's words (``a list``, ``a mapping``, ``a number``),
    never a Python class name: messages about a file's values name what the user wrote."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int):
        return "an integer"
    if isinstance(value, float):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, (bytes, bytearray)):
        return "binary data"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, (list, tuple)):
        return "a list"
    return "a value"


def shown(value: Any) -> str:
    """``repr(value)`` for an error message: short, bounded work, never raising.

    A hostile file can hold a list of millions of items or a number of thousands of
    digits; a message quotes only its beginning.
    """
    try:
        return _SHOWN.repr(value)
    except Exception:  # noqa: BLE001 - a message must never fail to be written
        return f"<{type(value).__name__}>"
