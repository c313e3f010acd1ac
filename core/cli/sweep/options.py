"""The sweep's command-line values: ``--seeds A-B`` and ``--scheduler tcp://HOST:PORT``."""

from __future__ import annotations

import re

from armtree.errors import ConfigError

_RANGE = re.compile(r"^\s*(\d+)\s*(?:-\s*(\d+))?\s*$")
#: The most seeds one sweep takes: a typo with three zeros too many is refused, not a
#: list of a billion runs built in memory before the first one starts.
MAX_SEEDS = 1_000_000
_ADDRESS = re.compile(r"^(tcp|tls|ws|wss)://(\[[0-9a-fA-F:.]+\]|[A-Za-z0-9_.-]+):(\d{1,5})$")


def parse_seeds(text: str) -> range:
    """The seeds ``text`` names: ``"1-1000"`` is 1 to 1000 inclusive, ``"7"`` is seed 7.

    Raises :class:`ConfigError` (at ``--seeds TEXT``) for anything else, or a range
    whose end comes before its start, or one of more than :data:`MAX_SEEDS` seeds.
    """
    match = _RANGE.match(text or "")
    if match is None:
        raise ConfigError(
            "give a range A-B of seeds >= 0 (e.g. 1-1000) or one seed N", file=f"--seeds {text}"
        )
    first = int(match.group(1))
    last = int(match.group(2)) if match.group(2) is not None else first
    if last < first:
        raise ConfigError(
            f"the range ends before it starts; write {last}-{first}", file=f"--seeds {text}"
        )
    if last - first + 1 > MAX_SEEDS:
        raise ConfigError(
            f"{last - first + 1} runs; one sweep takes at most {MAX_SEEDS:,} "
            "(split it into several --out folders)",
            file=f"--seeds {text}",
        )
    return range(first, last + 1)


def check_address(address: str) -> str:
    """``address`` when it reads ``tcp://HOST:PORT`` (or tls, ws, wss); else a ConfigError."""
    match = _ADDRESS.match(address or "")
    if match is None or not 0 < int(match.group(3)) < 65536:
        raise ConfigError(
            "give the scheduler's address as tcp://HOST:PORT "
            "(dask scheduler prints it as 'Scheduler at: ...')",
            file=f"--scheduler {address}",
        )
    return address
