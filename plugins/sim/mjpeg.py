"""A camera served as an MJPEG stream over HTTP on 127.0.0.1, as IP cameras serve one.

:class:`MjpegServer` serves ``/camera.mjpg`` (``multipart/x-mixed-replace``,
one JPEG per part, the format OpenCV's ``VideoCapture`` opens from a URL) and
``/snapshot.jpg`` (the newest frame). Whatever produces images calls
:meth:`MjpegServer.publish`; every connected client is sent each new frame
once, and a slow client skips frames rather than queueing them.
:meth:`MjpegServer.close` ends every client's connection and joins every
thread it started.
"""

from __future__ import annotations

import contextlib
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import cv2
import numpy as np

#: The multipart boundary between frames.
BOUNDARY = "armtreeframe"
#: Path of the stream and of a single frame.
STREAM_PATH = "/camera.mjpg"
SNAPSHOT_PATH = "/snapshot.jpg"


class FrameBoard:
    """The newest JPEG and its sequence number; clients wait here for the next one."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._jpeg: bytes | None = None
        self._seq = 0
        self._closed = False

    def publish(self, jpeg: bytes) -> int:
        """Make ``jpeg`` the newest frame; returns its sequence number."""
        with self._cond:
            self._jpeg = jpeg
            self._seq += 1
            self._cond.notify_all()
            return self._seq

    def newest(self) -> tuple[int, bytes | None]:
        """``(sequence, jpeg)`` of the newest frame (``(0, None)`` before the first)."""
        with self._cond:
            return self._seq, self._jpeg

    def wait_after(self, seq: int, timeout: float) -> tuple[int, bytes | None]:
        """The first frame newer than ``seq``, waiting up to ``timeout`` s; ``(seq, None)`` if none."""
        with self._cond:
            self._cond.wait_for(lambda: self._seq > seq or self._closed, timeout)
            if self._closed or self._seq <= seq:
                return seq, None
            return self._seq, self._jpeg

    def close(self) -> None:
        """Wake every waiting client so it can end."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    @property
    def closed(self) -> bool:
        """True once :meth:`close` was called."""
        return self._closed


class _Handler(BaseHTTPRequestHandler):
    server: _Server
    protocol_version = "HTTP/1.0"

    def do_GET(self) -> None:  # noqa: N802 - the name http.server calls
        path = self.path.split("?", 1)[0]
        if path == STREAM_PATH:
            self._stream()
        elif path == SNAPSHOT_PATH:
            self._snapshot()
        else:
            self.send_error(HTTPStatus.NOT_FOUND, f"the camera is at {STREAM_PATH}")

    def _snapshot(self) -> None:
        _, jpeg = self.server.board.newest()
        if jpeg is None:
            _, jpeg = self.server.board.wait_after(0, 2.0)
        if jpeg is None:
            self.send_error(HTTPStatus.SERVICE_UNAVAILABLE, "no frame yet")
            return
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", "image/jpeg")
        self.send_header("Content-Length", str(len(jpeg)))
        self.end_headers()
        self.wfile.write(jpeg)

    def _stream(self) -> None:
        board = self.server.board
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", f"multipart/x-mixed-replace; boundary={BOUNDARY}")
        self.send_header("Cache-Control", "no-cache")
        self.end_headers()
        seq, jpeg = board.newest()
        try:
            while not board.closed:
                if jpeg is not None:
                    head = (
                        f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\n"
                        f"Content-Length: {len(jpeg)}\r\n\r\n"
                    ).encode()
                    self.wfile.write(head + jpeg + b"\r\n")
                    self.wfile.flush()
                seq, jpeg = board.wait_after(seq, 0.5)
        except (BrokenPipeError, ConnectionResetError, OSError):
            return  # the client went away

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - http.server's name
        """Quiet: a bench server does not log every request."""


class _Server(ThreadingHTTPServer):
    daemon_threads = False  # close() joins the client threads
    block_on_close = True

    def __init__(self, address: tuple[str, int], board: FrameBoard) -> None:
        super().__init__(address, _Handler)
        self.board = board


class MjpegServer:
    """An HTTP server on ``host:port`` (port 0: any free one) streaming published frames.

    ``quality`` is the JPEG quality (0-100). :attr:`url` is the stream's URL.
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 0, quality: int = 90) -> None:
        self.board = FrameBoard()
        self.quality = int(quality)
        self._server = _Server((host, port), self.board)
        self._thread = threading.Thread(
            target=self._server.serve_forever,
            kwargs={"poll_interval": 0.1},
            name="mjpeg server",
            daemon=True,
        )
        self._started = False
        #: How many frames were published.
        self.frames_published = 0

    @property
    def port(self) -> int:
        """The TCP port the server listens on."""
        return int(self._server.server_address[1])

    @property
    def url(self) -> str:
        """The stream's URL, e.g. ``http://127.0.0.1:8081/camera.mjpg``."""
        host = self._server.server_address[0]
        # typeshed allows bytes for any address family; an AF_INET socket names a str.
        if isinstance(host, (bytes, bytearray)):
            host = host.decode()
        return f"http://{host}:{self.port}{STREAM_PATH}"

    def start(self) -> str:
        """Start serving; returns :attr:`url`."""
        if not self._started:
            self._started = True
            self._thread.start()
        return self.url

    def encode(self, image: np.ndarray) -> bytes:
        """``image`` (BGR or grey, uint8) as JPEG bytes."""
        ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, self.quality])
        if not ok:
            raise ValueError("JPEG encoding failed")
        return buf.tobytes()

    def publish(self, image: np.ndarray) -> int:
        """Encode ``image`` and send it to every client; returns its sequence number."""
        seq = self.board.publish(self.encode(image))
        self.frames_published += 1
        return seq

    def close(self) -> None:
        """End every client's stream, stop serving and join the threads; safe to call twice."""
        self.board.close()
        if self._started:
            with contextlib.suppress(Exception):
                self._server.shutdown()
            self._thread.join(timeout=2.0)
        with contextlib.suppress(Exception):
            self._server.server_close()


__all__ = ["BOUNDARY", "SNAPSHOT_PATH", "STREAM_PATH", "FrameBoard", "MjpegServer"]
