"""The exceptions armtree raises to users, each carrying where and how to fix it."""

from __future__ import annotations

from dataclasses import dataclass


class ConfigError(ValueError):
    """Invalid input: a tree, a profile, a parameter, a plugin or a command-line value.

    Carries ``file``, ``line`` and ``column`` (1-based; ``None`` when unknown) so the
    CLI can print ``FILE:LINE:COL: message``. ``errors`` holds every problem found in
    one file when several were collected; ``str()`` of the exception lists them all.
    Nothing moves before a tree and its profile validate.
    """

    def __init__(
        self,
        message: str,
        file: str | None = None,
        line: int | None = None,
        column: int | None = None,
        errors: list[ConfigError] | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.column = column
        self.errors: list[ConfigError] = errors if errors else [self]

    def location(self) -> str:
        """Return ``FILE:LINE:COL`` (or as much of it as is known)."""
        parts = [self.file or "<input>"]
        if self.line is not None:
            parts.append(str(self.line))
            if self.column is not None:
                parts.append(str(self.column))
        return ":".join(parts)

    def format(self) -> str:
        """Every collected error as ``FILE:LINE:COL: message``, one per line."""
        return "\n".join(f"{e.location()}: {e.message}" for e in self.errors)

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
