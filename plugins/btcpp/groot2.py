"""The Groot2 monitor protocol (BehaviorTree.CPP 4's ``Groot2Publisher``), served for an
armtree run so Groot2, btview or any BT.CPP tool shows it live.

ZeroMQ, on 127.0.0.1: a REP socket on PORT answers requests, a PUB socket on PORT + 1
is bound as BT.CPP binds it (it carries breakpoint notices, which armtree does not
send). Every message is multipart.

* Request: frame 0 is 6 bytes, ``u8`` protocol (2), ``u8`` type, ``u32`` id (little
  endian); a blackboard request has a second frame. Reply: the same 6 bytes (protocol
  2) and the 16-byte id of this tree, then the payload; a refused request is answered
  ``["error", why]``.
* ``T``: the tree as XML with ``_uid`` on every node (:mod:`.monitor_tree`).
* ``S``: the status buffer, ``u16`` uid and ``u8`` status per node.
* ``B``: second frame ``name;name``; the reply a MessagePack map ``{name: {key: value}}``.
  armtree has one blackboard: the tree's name (or no name) gives every key; a subtree
  namespace gives its keys.
* ``D`` hooks dump (``[]``), ``A`` remove all hooks, ``X`` disable all hooks: answered
  with nothing to report. Breakpoints (``I``, ``R``, ``U``) and recording (``r``,
  ``t``) are refused with a reason: the run log has every transition.
"""

from __future__ import annotations

import contextlib
import struct
import threading
import uuid
from collections.abc import Callable
from typing import Any

import msgpack
import zmq

from armtree.errors import HardwareFault

#: BT.CPP's ``Monitor::kProtocolID``.
PROTOCOL = 2
_HEADER = struct.Struct("<BBI")
_NO_BREAKPOINTS = (
    "armtree serves no breakpoints; pause and step the run with run-tree's keys "
    "(p, n, r) or the --monitor page"
)
_NO_RECORDING = "armtree records every transition in the run log (run.jsonl), not for Groot2"


class Groot2Server:
    """The two sockets, and a thread answering requests from what the run last published.

    :attr:`tree_xml` and :attr:`status` are replaced whole by the run's thread (bytes,
    so the serving thread always sends one consistent value); ``blackboard(names)``
    returns ``{name: {key: value}}`` of JSON values.
    """

    def __init__(
        self,
        port: int,
        blackboard: Callable[[list[str]], dict[str, Any]],
        host: str = "127.0.0.1",
    ) -> None:
        self.host = host
        self.blackboard = blackboard
        self.tree_xml = b""
        self.status = b""
        self.tree_id = uuid.uuid4().bytes
        self._context = zmq.Context()
        self._server = self._context.socket(zmq.REP)
        self._publisher = self._context.socket(zmq.PUB)
        for socket in (self._server, self._publisher):
            socket.setsockopt(zmq.LINGER, 0)
        self._server.setsockopt(zmq.SNDTIMEO, 1000)
        self.port = self._bind(port)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def _bind(self, port: int) -> int:
        """Bind PORT and PORT + 1 (a free pair when ``port`` is 0); HardwareFault naming
        the port already in use."""
        tries = 20 if port == 0 else 1
        for _ in range(tries):
            chosen = port
            try:
                if port == 0:
                    chosen = self._server.bind_to_random_port(
                        f"tcp://{self.host}", min_port=20000, max_port=60000
                    )
                else:
                    self._bind_one(self._server, port)
            except zmq.ZMQError:
                self.close()
                raise self._busy(port) from None
            try:
                self._bind_one(self._publisher, chosen + 1)
                return chosen
            except zmq.ZMQError:
                self._server.unbind(self._server.getsockopt_string(zmq.LAST_ENDPOINT))
                if port != 0:
                    self.close()
                    raise self._busy(chosen + 1) from None
        self.close()
        raise HardwareFault("found no two free consecutive ports", device=f"{self.host}")

    def _bind_one(self, socket: zmq.Socket, port: int) -> None:
        socket.bind(f"tcp://{self.host}:{port}")

    def _busy(self, port: int) -> HardwareFault:
        return HardwareFault(
            f"cannot serve the Groot2 monitor: port {port} is already in use; "
            "stop what uses it or give another with --groot2 PORT (the next port is used too)",
            device=f"{self.host}:{port}",
        )

    def start(self) -> None:
        """Answer requests on a thread of its own until :meth:`close`."""
        self._thread = threading.Thread(target=self._serve, name="groot2", daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        poller = zmq.Poller()
        poller.register(self._server, zmq.POLLIN)
        while not self._stop.is_set():
            if not poller.poll(100):
                continue
            try:
                frames = self._server.recv_multipart(zmq.NOBLOCK)
            except zmq.ZMQError:
                continue
            try:
                self._server.send_multipart(self.reply(frames))
            except zmq.ZMQError:
                continue

    def reply(self, frames: list[bytes]) -> list[bytes]:
        """The reply frames to one request."""
        if not frames or len(frames[0]) != _HEADER.size:
            return [b"error", b"wrong request header"]
        _, kind, request_id = _HEADER.unpack(frames[0])
        head = _HEADER.pack(PROTOCOL, kind, request_id) + self.tree_id
        request = chr(kind)
        if request == "T":
            return [head, self.tree_xml]
        if request == "S":
            return [head, self.status]
        if request == "B":
            if len(frames) != 2:
                return [b"error", b"must be 2 parts message"]
            names = frames[1].decode("utf-8", "replace").split(";")
            return [head, msgpack.packb(self.blackboard(names), use_bin_type=True)]
        if request == "D":
            return [head, b"[]"]
        if request in "AX":
            return [head]
        if request in "IRU":
            return [b"error", _NO_BREAKPOINTS.encode()]
        if request in "rt":
            return [b"error", _NO_RECORDING.encode()]
        return [b"error", b"Request not recognized"]

    def close(self) -> None:
        """Stop answering and close both sockets (safe to call twice)."""
        if getattr(self, "_stop", None) is not None:
            self._stop.set()
        thread = getattr(self, "_thread", None)
        if thread is not None:
            thread.join(timeout=2)
        with contextlib.suppress(Exception):
            self._context.destroy(linger=0)
