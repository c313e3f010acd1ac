"""The BehaviorTree.CPP plugin's hooks: XML tree files, ``armtree export``, ``--groot2``.

The Groot2 hooks read the run only through public names (``run.settings``,
``run.nodes``, ``run.node_paths``, ``run.statuses``, ``run.tree``, ``run.plugin_state``,
``run.closers``, ``run.control``)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import armtree
from armtree.runtime.runner import Run

from .reader import read_tree

#: Groot2Publisher's default port (its PUB socket is the next one).
DEFAULT_PORT = 1667


@armtree.hookimpl
def armtree_read_tree(path: Path) -> Any:
    """BehaviorTree.CPP v4 XML (``.xml``) as tree file data."""
    return read_tree(path)


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """``armtree export``."""
    from .export_command import ExportCommand

    return {"export": ExportCommand()}


def port_number(text: str) -> int:
    """An argparse type: a TCP port for --groot2, 0 (any free pair) to 65534."""
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a port number; write the tree first: run-tree TREE --groot2 [PORT]"
        ) from None
    if not 0 <= port <= 65534:
        raise argparse.ArgumentTypeError(
            f"{port} is not a port: give 1-65534 (the next port is used too), or 0 for any free pair"
        )
    return port


@armtree.hookimpl
def armtree_run_options(parser: argparse.ArgumentParser) -> None:
    """``--groot2 [PORT]``."""
    parser.add_argument_group("groot2").add_argument(
        "--groot2",
        nargs="?",
        const=DEFAULT_PORT,
        type=port_number,
        metavar="PORT",
        help=f"serve the Groot2 monitor protocol on 127.0.0.1:PORT and PORT+1 (default "
        f"{DEFAULT_PORT}; 0: any free pair), so Groot2 or btview show the run live; a "
        "simulated run then keeps to real time",
    )


@armtree.hookimpl
def armtree_run_opening(run: Run) -> None:
    """Bind the Groot2 sockets before anything is built (a port in use is exit 3)."""
    port = run.settings.get("groot2")
    if port is None:
        return
    from .live import KEY, Groot2Session

    session = Groot2Session(run, port)
    run.plugin_state[KEY] = session
    run.closers.append(session.close)
    if run.clock.virtual and run.control.speed is None:
        run.control.speed = 1.0
    print(
        f"groot2: serving 127.0.0.1:{session.server.port} (and {session.server.port + 1})",
        flush=True,
    )


@armtree.hookimpl
def armtree_run_started(run: Run) -> None:
    """Publish the tree and start answering Groot2."""
    session = run.plugin_state.get("btcpp.groot2")
    if session is not None:
        session.start()


@armtree.hookimpl
def armtree_tick(run: Run) -> None:
    """Publish the tick's statuses."""
    session = run.plugin_state.get("btcpp.groot2")
    if session is not None:
        session.tick()


@armtree.hookimpl
def armtree_tree_replaced(run: Run, previous: Any) -> None:
    """A --watch reload: describe the new tree."""
    session = run.plugin_state.get("btcpp.groot2")
    if session is not None:
        session.reindex()


@armtree.hookimpl
def armtree_run_finished(run: Run, result: Any) -> None:
    """The statuses the run ended with (halted nodes idle)."""
    session = run.plugin_state.get("btcpp.groot2")
    if session is not None:
        session.tick()
