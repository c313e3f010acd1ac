"""The monitor page and its websocket, served by aiohttp on a thread of its own.

The page is static files shipped in this package (``static/``: no build step,
nothing fetched from elsewhere, so it works offline). One websocket per open
page carries JSON messages (and camera frames as binary messages); every page
sees the same broadcasts, and what a page sends goes to the :class:`Handler`
once. Bound to anything but loopback the server requires the token printed at
start, on the page (``?token=``) and on the websocket.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import ipaddress
import json
import secrets
import socket
import threading
from collections.abc import Callable
from importlib import resources
from typing import Any, Protocol

from aiohttp import WSMsgType, web

from armtree.errors import ConfigError

#: Messages waiting for one slow page before it is sent a fresh snapshot instead.
_BACKLOG = 300
_STATIC = {
    "index.html": "text/html",
    "app.js": "text/javascript",
    "tree.js": "text/javascript",
    "views.js": "text/javascript",
    "style.css": "text/css",
    "favicon.svg": "image/svg+xml",
}


class Handler(Protocol):
    """What feeds the server: the live run or a recording."""

    def hello(self) -> list[dict[str, Any]]:
        """The messages a newly opened page needs to show everything so far."""

    def on_message(self, client: Client, message: dict[str, Any]) -> None:
        """A page sent ``message`` (a control, a seek); called on the server's thread."""

    def on_clients(self, count: int) -> None:
        """The number of open pages changed."""


def is_loopback(host: str) -> bool:
    """True for 127.0.0.0/8, ::1 and ``localhost``."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class Client:
    """One open page: its websocket and its queue of outgoing messages."""

    def __init__(self, ws: web.WebSocketResponse, number: int) -> None:
        self.ws = ws
        self.number = number
        self.queue: asyncio.Queue = asyncio.Queue()
        #: The page has drawn the last camera frame sent and can take another.
        self.ready_for_image = True


class PageServer:
    """Serves the page at ``http://HOST:PORT/`` and broadcasts to every open page.

    :meth:`start` binds (raising :class:`ConfigError` for a port in use or a
    refused bind) and returns the URL; :meth:`broadcast` and
    :meth:`broadcast_binary` may be called from any thread; :meth:`stop`
    flushes and closes.
    """

    def __init__(
        self,
        handler: Handler,
        host: str = "127.0.0.1",
        port: int = 8765,
        option: str = "--monitor",
        host_option: str = "--monitor-host",
    ) -> None:
        self.handler = handler
        self.host_option = host_option
        self.host = host
        self.port = port
        self.option = option
        self.token = None if is_loopback(host) else secrets.token_urlsafe(12)
        self.clients: list[Client] = []
        self.loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._runner: web.AppRunner | None = None
        self._numbers = 0
        self._stopped = False

    # ------------------------------------------------------------------
    # Life
    # ------------------------------------------------------------------

    @property
    def url(self) -> str:
        """Where to point a browser (with the token when one is needed)."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        query = f"?token={self.token}" if self.token else ""
        return f"http://{host}:{self.port}/{query}"

    def start(self) -> str:
        """Bind and serve on a new thread; the URL. Raises :class:`ConfigError` if it cannot bind."""
        ready = threading.Event()
        failure: list[BaseException] = []
        # the thread runs this loop, the one self.loop names from here on (never None)
        loop = self.loop = asyncio.new_event_loop()

        def serve() -> None:
            asyncio.set_event_loop(loop)
            try:
                loop.run_until_complete(self._bind())
            except BaseException as exc:  # noqa: BLE001 - handed to the starting thread
                failure.append(exc)
                ready.set()
                return
            ready.set()
            loop.run_forever()
            loop.run_until_complete(self._shutdown())
            loop.close()

        self._thread = threading.Thread(target=serve, name="armtree-monitor", daemon=True)
        self._thread.start()
        ready.wait()
        if failure:
            self._thread.join()
            raise self._bind_error(failure[0])
        return self.url

    def _bind_error(self, exc: BaseException) -> BaseException:
        where = f"{self.host}:{self.port}"
        code = getattr(exc, "errno", None)
        if code == errno.EADDRINUSE:
            return ConfigError(
                f"port {self.port} on {self.host} is already in use (another monitor, or another "
                f"program); give another: {self.option} PORT, or {self.option} 0 for any free one",
                file=self.option,
            )
        if code in (errno.EACCES, errno.EPERM):
            return ConfigError(
                f"not allowed to listen on {where} (ports below 1024 need privileges); "
                "give a port above 1023",
                file=self.option,
            )
        if code == errno.EADDRNOTAVAIL or isinstance(exc, socket.gaierror):
            return ConfigError(
                f"cannot listen on {where}: {self.host} is not an address of this machine; "
                "give one of its addresses (0.0.0.0 for all)",
                file=self.host_option,
            )
        if isinstance(exc, OSError):
            return ConfigError(f"cannot listen on {where}: {exc.strerror or exc}", file=self.option)
        return exc

    async def _bind(self) -> None:
        app = web.Application(middlewares=[self._guard])
        app.router.add_get("/", self._index)
        app.router.add_get("/ws", self._websocket)
        app.router.add_get("/static/{name}", self._static)
        self._runner = web.AppRunner(app, access_log=None, handle_signals=False)
        await self._runner.setup()
        site = web.TCPSite(self._runner, self.host, self.port, reuse_address=False)
        try:
            await site.start()
        except BaseException:
            await self._runner.cleanup()
            raise
        server = getattr(site, "_server", None)
        sockets = getattr(server, "sockets", None) or ()
        if sockets:
            self.port = int(sockets[0].getsockname()[1])

    def stop(self, grace: float = 1.0) -> None:
        """Send what is queued (waiting up to ``grace`` s), close every page and stop."""
        if self._stopped or self.loop is None or self._thread is None:
            return
        self._stopped = True
        if self.loop.is_running():
            future = asyncio.run_coroutine_threadsafe(self._drain(grace), self.loop)
            with contextlib.suppress(Exception):
                future.result(grace + 1.0)
            self.loop.call_soon_threadsafe(self.loop.stop)
        self._thread.join(grace + 2.0)

    async def _drain(self, grace: float) -> None:
        deadline = asyncio.get_running_loop().time() + grace
        while any(not c.queue.empty() for c in self.clients):
            if asyncio.get_running_loop().time() > deadline:
                break
            await asyncio.sleep(0.02)

    async def _shutdown(self) -> None:
        for client in list(self.clients):
            with contextlib.suppress(Exception):
                await client.ws.close(code=1001, message=b"the run is over")
        if self._runner is not None:
            await self._runner.cleanup()

    # ------------------------------------------------------------------
    # Sending (any thread)
    # ------------------------------------------------------------------

    def call(self, function: Callable[..., Any], *args: Any) -> None:
        """Run ``function(*args)`` on the server's thread."""
        loop = self.loop
        if loop is not None and not self._stopped and loop.is_running():
            with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
                loop.call_soon_threadsafe(function, *args)

    def broadcast(self, message: dict[str, Any]) -> None:
        """Send ``message`` (JSON) to every open page (nothing is encoded while none is open)."""
        if self.clients:
            self.call(self._enqueue_all, json.dumps(message, separators=(",", ":")))

    def broadcast_binary(self, data: bytes, only_ready: bool = True) -> None:
        """Send a binary message (a camera frame) to every page ready for one."""
        self.call(self._enqueue_binary, data, only_ready)

    def _enqueue_all(self, text: str) -> None:
        for client in self.clients:
            if client.queue.qsize() > _BACKLOG:
                # Too slow to keep up: start it again from a snapshot.
                while not client.queue.empty():
                    client.queue.get_nowait()
                for message in self.handler.hello():
                    client.queue.put_nowait(json.dumps(message, separators=(",", ":")))
            else:
                client.queue.put_nowait(text)

    def _enqueue_binary(self, data: bytes, only_ready: bool) -> None:
        for client in self.clients:
            if not only_ready or client.ready_for_image:
                client.ready_for_image = False
                client.queue.put_nowait(data)

    def send(self, client: Client, message: dict[str, Any]) -> None:
        """Send ``message`` to one page (on the server's thread)."""
        client.queue.put_nowait(json.dumps(message, separators=(",", ":")))

    @property
    def any_ready_for_image(self) -> bool:
        """True when some page can take a camera frame."""
        return any(c.ready_for_image for c in self.clients)

    # ------------------------------------------------------------------
    # Requests
    # ------------------------------------------------------------------

    @web.middleware
    async def _guard(self, request: web.Request, handler: Any) -> web.StreamResponse:
        if self.token is not None and not secrets.compare_digest(
            request.query.get("token", ""), self.token
        ):
            return web.Response(
                status=403,
                text="This monitor needs the token printed when the run started: "
                "open the URL shown there (it ends in ?token=...).\n",
            )
        return await handler(request)

    async def _index(self, request: web.Request) -> web.StreamResponse:
        return self._file("index.html")

    async def _static(self, request: web.Request) -> web.StreamResponse:
        name = request.match_info["name"]
        if name not in _STATIC:
            raise web.HTTPNotFound()
        return self._file(name)

    def _file(self, name: str) -> web.Response:
        data = (resources.files(__package__) / "static" / name).read_bytes()
        return web.Response(
            body=data,
            content_type=_STATIC[name],
            headers={
                "Cache-Control": "no-store",
                "Content-Security-Policy": "default-src 'self'; img-src 'self' blob: data:; "
                "style-src 'self' 'unsafe-inline'; connect-src 'self'",
            },
        )

    async def _websocket(self, request: web.Request) -> web.StreamResponse:
        ws = web.WebSocketResponse(heartbeat=20.0, max_msg_size=1 << 16)
        await ws.prepare(request)
        self._numbers += 1
        client = Client(ws, self._numbers)
        for message in self.handler.hello():
            self.send(client, message)
        self.clients.append(client)
        self.handler.on_clients(len(self.clients))
        sender = asyncio.create_task(self._sender(client))
        try:
            async for msg in ws:
                if msg.type != WSMsgType.TEXT:
                    continue
                try:
                    data = json.loads(msg.data)
                except ValueError:
                    continue
                if not isinstance(data, dict):
                    continue
                if data.get("type") == "image_ack":
                    client.ready_for_image = True
                    continue
                self.handler.on_message(client, data)
        finally:
            sender.cancel()
            if client in self.clients:
                self.clients.remove(client)
            self.handler.on_clients(len(self.clients))
        return ws

    async def _sender(self, client: Client) -> None:
        ws = client.ws
        with contextlib.suppress(Exception):
            while not ws.closed:
                item = await client.queue.get()
                if isinstance(item, bytes):
                    await ws.send_bytes(item)
                else:
                    await ws.send_str(item)


def image_message(header: dict[str, Any], jpeg: bytes) -> bytes:
    """A camera frame as one binary message: 4-byte header length, JSON header, JPEG."""
    head = json.dumps(header, separators=(",", ":")).encode()
    return len(head).to_bytes(4, "big") + head + jpeg


__all__ = ["Client", "Handler", "PageServer", "image_message", "is_loopback"]
