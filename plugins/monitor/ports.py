"""The port options of the monitor's page (``run-tree --monitor [PORT]``, ``armtree replay
--port``): a TCP port, 0 (any free one) to 65535, or a usage error naming the value."""

from __future__ import annotations

import argparse

MONITOR_HINT = "write the tree first: run-tree TREE --monitor [PORT]"


def port_number(text: str, hint: str = MONITOR_HINT) -> int:
    """An argparse type: a TCP port, 0 (any free one) to 65535; ``hint`` ends the
    message for text that is no number."""
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port number; {hint}") from None
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(
            f"{port} is not a port: give 1-65535, or 0 for any free one"
        )
    return port


def replay_port(text: str) -> int:
    """``armtree replay --port``: :func:`port_number` with its own hint."""
    return port_number(text, "give a number from 0 (any free port) to 65535")
