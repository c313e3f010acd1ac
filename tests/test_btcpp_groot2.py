"""run-tree --groot2: a simulated load_ducky served with the Groot2 protocol, read by an
independent client (btview); what it shows agrees with the run log."""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import struct
import subprocess
import sys
from pathlib import Path

import msgpack
import pytest
import zmq

import armtree
from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.plugins.btcpp.groot2 import Groot2Server
from armtree.runtime.runlog import read_log

BTVIEW = [sys.executable, "-m", "btview"]
#: One line of ``btview snapshot --ascii --uid``: name, type, uid, status.
LINE = re.compile(
    r"^[|`+\- ]*\S+ (?P<name>.+?) \[(?P<type>[^\]]+)\] #(?P<uid>\d+)\s+\S (?P<status>[A-Z]+)$"
)


def btview(*args: str) -> str:
    result = subprocess.run(
        [*BTVIEW, *args],
        capture_output=True,
        text=True,
        timeout=60,
        env={**os.environ, "COLUMNS": "400", "NO_COLOR": "1"},
    )
    assert result.returncode == 0, result.stdout + result.stderr
    return result.stdout


def preorder_paths(tree: armtree.Tree) -> list[tuple[str, str]]:
    """(path, name) of every node, parents first (the order btview prints)."""
    found, todo = [], [tree.root]
    while todo:
        node = todo.pop()
        found.append((tree.nodes[node.id].path, node.name))
        todo.extend(reversed(node.children))
    return found


def statuses_by_tick(log: list[dict], paths: list[str]) -> list[dict[str, str]]:
    """Every node's status after each tick, from the run log's status records."""
    state = dict.fromkeys(paths, "IDLE")
    ticks: dict[int, dict[str, str]] = {}
    for record in log:
        if record["kind"] == "status":
            state[record["node"]] = "IDLE" if record["to"] == "INVALID" else record["to"]
            ticks[record["tick"]] = dict(state)
    return list(ticks.values())


@pytest.mark.slow
def test_btview_shows_the_running_tree_and_blackboard_as_the_run_log_has_them(tmp_path):
    record = tmp_path / "run"
    run = subprocess.Popen(
        ["run-tree", "load_ducky.yaml", "--groot2", "0", "--quiet", "--record", str(record)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        first = run.stdout.readline()
        port = re.match(r"groot2: serving 127\.0\.0\.1:(\d+) \(and (\d+)\)", first)
        assert port, first + run.stderr.read()
        assert int(port.group(2)) == int(port.group(1)) + 1
        # a simulated run keeps to real time while served: ask until a leaf is running
        for _ in range(20):
            snapshot = btview("snapshot", "-p", port.group(1), "--ascii", "--no-color", "--uid")
            nodes = [LINE.match(line) for line in snapshot.splitlines() if "#" in line]
            if any(
                n and n["status"] == "RUNNING" and n["type"] in ("sweep", "pick", "look")
                for n in nodes
            ):
                break
        board = json.loads(btview("blackboard", "-p", port.group(1), "--json"))
    finally:
        run.send_signal(signal.SIGINT)
        run.communicate(timeout=60)
    assert run.returncode == 130
    tree = armtree.load_tree("load_ducky", manager=get_plugin_manager())
    expected = preorder_paths(tree)
    assert all(nodes), snapshot
    assert [(n["name"], int(n["uid"])) for n in nodes] == [
        (name, i + 1) for i, (_, name) in enumerate(expected)
    ]
    types = {n["name"]: n["type"] for n in nodes}
    assert types["Load a ducky"] == "Sequence" and types["Holding the ducky?"] == "holding"
    assert types["Find the Duckybot and wait for it to park"] == "RetryUntilSuccessful"
    shown = {path: n["status"] for (path, _), n in zip(expected, nodes, strict=True)}
    log = read_log(record / "run.jsonl")
    ticks = statuses_by_tick(log, [p for p, _ in expected])
    assert shown in ticks, "btview's statuses are those of no tick of the run log"
    assert "RUNNING" in shown.values()
    written = {r["key"].lstrip("/"): r["value"] for r in log if r["kind"] == "blackboard"}
    assert board["load_ducky"]["clean_up"] is True
    assert set(board["load_ducky"]) <= set(written) | {"clean_up", "trash_skipped"}


def test_the_server_answers_the_protocol_byte_for_byte():
    server = Groot2Server(0, lambda names: {"t": {"k": 1}} if "t" in names else {})
    server.tree_xml, server.status = b"<root/>", struct.pack("<HBHB", 1, 2, 2, 11)
    server.start()
    context = zmq.Context()
    client = context.socket(zmq.REQ)
    client.setsockopt(zmq.RCVTIMEO, 5000)
    client.setsockopt(zmq.LINGER, 0)
    client.connect(f"tcp://127.0.0.1:{server.port}")
    try:

        def ask(kind: str, *extra: bytes) -> list[bytes]:
            client.send_multipart([struct.pack("<BBI", 2, ord(kind), 0xDEADBEEF), *extra])
            return client.recv_multipart()

        head, xml = ask("T")
        assert head[:6] == struct.pack("<BBI", 2, ord("T"), 0xDEADBEEF) and len(head) == 22
        assert head[6:] == server.tree_id and xml == b"<root/>"
        assert ask("S")[1] == b"\x01\x00\x02\x02\x00\x0b"
        assert msgpack.unpackb(ask("B", b"t;u")[1]) == {"t": {"k": 1}}
        assert ask("B") == [b"error", b"must be 2 parts message"]
        assert ask("D")[1] == b"[]" and len(ask("A")) == 1
        assert ask("I", b"{}")[0] == b"error"
        client.send_multipart([b"abc"])
        assert client.recv_multipart() == [b"error", b"wrong request header"]
    finally:
        client.close()
        context.term()
        server.close()


def test_a_groot2_port_in_use_is_exit_3_naming_it(tmp_path):
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        result = subprocess.run(
            [
                "run-tree",
                "load_ducky.yaml",
                "--groot2",
                str(port),
                "--quiet",
                "--record",
                str(tmp_path / "r"),
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert result.returncode == 3
    assert (
        f"127.0.0.1:{port}: cannot serve the Groot2 monitor: port {port} is already in use"
        in result.stderr
    )
    assert "Traceback" not in result.stderr
    assert not Path(tmp_path / "r").exists()  # refused before anything was built
