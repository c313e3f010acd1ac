"""Pseudo-terminal plumbing every arm firmware emulator shares.

A subclass of :class:`PtyEmulator` writes only the firmware: what to do with
bytes received (:meth:`PtyEmulator.on_bytes`), which timed events it has
(:meth:`PtyEmulator.next_event_time` / :meth:`PtyEmulator.on_timer`, e.g. a
status frame every 50 ms or a 20 ms step slot), and its tool state. This base
opens the pty, keeps the slave side raw, sends and receives on the master fd,
runs the deterministic step loop, injects faults and integrates joint motion
(:attr:`PtyEmulator.joints`).

Step loop (``step(now)``): bytes the driver wrote since the last step are
handled at the previous time; then every timed event up to ``now`` fires in
order. After each of these the emulator settles: it waits (through
:class:`~.barrier.StepBarrier`) until the driver has handled what was sent,
reads the answers and handles them, until both sides are quiet. Only then is
the tick ``now`` announced to the driver, and the settling is repeated. On a wall clock (``armtree emulate``,
``--realtime``) a service thread steps the emulator every few milliseconds and
the barrier is never used.

Packet mode: the master side runs in the pty's packet mode (``TIOCPKT``), so
every read starts with a status byte: 0 (``TIOCPKT_DATA``) before data the
host wrote, or control flags alone. A pty carries no DTR line, but pyserial's
``open()`` flushes the port's input, which packet mode reports as
``TIOCPKT_FLUSHREAD``; the base strips the status byte (:func:`parse_packet`)
and tells the firmware through :meth:`PtyEmulator.on_port_opened`, so a board
that resets when its port is opened (an Arduino through DTR) can do so. Every
flush counts as an open: no driver calls ``reset_input_buffer()`` after
opening the port.
"""

from __future__ import annotations

import collections
import contextlib
import fcntl
import os
import select
import struct
import termios
import threading
import time
import tty
from abc import abstractmethod

import numpy as np

from armtree.api.clock import Clock
from armtree.api.emulation import FirmwareEmulator
from armtree.maths.motion.kinematics import KinematicModel

from .barrier import StepBarrier
from .motion import JointState

#: Faults :meth:`PtyEmulator.inject` understands.
FAULTS = ("corrupt", "drop", "cut", "missed_steps")

#: Packet-mode status byte before data, and the control flag of a flushed input queue
#: (Linux and the BSDs define these values; ``termios`` may lack the names).
TIOCPKT_DATA = getattr(termios, "TIOCPKT_DATA", 0x00)
TIOCPKT_FLUSHREAD = getattr(termios, "TIOCPKT_FLUSHREAD", 0x01)
_TIOCPKT = getattr(termios, "TIOCPKT", None)


def parse_packet(chunk: bytes) -> tuple[int, bytes]:
    """One read of a packet-mode pty master as ``(control flags, data)``.

    A read is either data (status byte ``TIOCPKT_DATA`` followed by the bytes)
    or a control report (the flags byte alone, no data); an empty read is
    ``(0, b"")``.
    """
    if not chunk:
        return 0, b""
    status = chunk[0]
    if status == TIOCPKT_DATA:
        return 0, bytes(chunk[1:])
    return status, b""


class PtyEmulator(FirmwareEmulator):
    """Base of every firmware emulator: a pseudo-terminal, the step loop and fault injection.

    ``model`` gives the joints' limits, speeds and accelerations; ``clock`` is
    the run's clock (virtual: the runtime steps the emulator; wall: a service
    thread does); ``seed`` drives fault injection; ``q0`` is the power-up pose
    (default ``model.home``), degrees / mm.
    """

    #: Wall seconds between service-thread steps on a wall clock.
    service_period = 0.002

    def __init__(
        self,
        model: KinematicModel,
        clock: Clock,
        *,
        seed: int = 0,
        q0: np.ndarray | None = None,
    ) -> None:
        self.model = model
        self.clock = clock
        self.barrier = StepBarrier()
        self.joints = JointState(
            model.home if q0 is None else q0,
            np.array([j.max_speed for j in model.joints]),
            np.array([j.max_accel for j in model.joints]),
        )
        self.path: str | None = None
        #: ``(time, "rx" | "tx", bytes)`` of the last few thousand exchanges, for tests and logs.
        self.transcript: collections.deque[tuple[float, str, bytes]] = collections.deque(
            maxlen=4096
        )
        self.halted_reason: str | None = None
        self._time = clock.now()
        self._rng = np.random.default_rng(seed)
        self._lock = threading.RLock()
        self._master: int | None = None
        self._slave: int | None = None
        self._packet = False
        #: Opens of the port seen (input flushes in packet mode).
        self.port_opens = 0
        self._silent = False
        self._corrupt_rate = 0.0
        self._corrupt_count = 0
        self._drop_rate = 0.0
        self._drop_count = 0
        self._service: threading.Thread | None = None
        self._stop = threading.Event()

    # ------------------------------------------------------------------ firmware hooks

    @abstractmethod
    def on_bytes(self, data: bytes, t: float) -> None:
        """Handle bytes received from the host at time ``t`` (reply with :meth:`send`)."""

    def next_event_time(self) -> float | None:
        """Time of the next timed event (strictly after those already handled), or None."""
        return None

    def on_timer(self, t: float) -> None:  # noqa: B027 - firmware without timed events
        """Handle every timed event due at or before ``t``."""

    def on_start(self) -> None:  # noqa: B027 - firmware with nothing to do at power-up
        """Power-up: called once the pty is open, before the first step."""

    def on_port_opened(self, t: float) -> None:  # noqa: B027 - boards that ignore the open
        """A host opened the port (its input was flushed), seen at time ``t`` (s).

        The default does nothing; a board that resets on open (DTR) reboots here.
        """

    # ------------------------------------------------------------------ FirmwareEmulator

    @property
    def time(self) -> float:
        """The emulator's current time, seconds on the run clock."""
        return self._time

    def start(self) -> str:
        """Open the pseudo-terminal and return the slave's device path (e.g. ``/dev/pts/7``)."""
        with self._lock:
            if self.path is not None:
                return self.path
            master, slave = os.openpty()
            tty.setraw(slave)
            flags = fcntl.fcntl(master, fcntl.F_GETFL)
            fcntl.fcntl(master, fcntl.F_SETFL, flags | os.O_NONBLOCK)
            self._packet = _packet_mode(master)
            # Holding the slave open keeps the master readable while no driver has the
            # port open (a driver may close and reopen it, as after a USB reset).
            self._master, self._slave = master, slave
            self.path = os.ttyname(slave)
            self._time = self.clock.now()
            self.on_start()
        if not self.clock.virtual:
            self._service = threading.Thread(
                target=self._serve, name=f"emulator {self.path}", daemon=True
            )
            self._service.start()
        return self.path

    def step(self, now: float) -> None:
        """Handle received bytes, fire timed events up to ``now`` and settle with the driver."""
        with self._lock:
            if self._master is None:
                return
            # Every exchange is finished at the time it belongs to before the next tick
            # is announced, so the driver never sees a reply early or late.
            self._pump_input(complete=True)
            self._settle(None)
            while True:
                t = self.next_event_time()
                if t is None or t > now:
                    break
                self._time = max(self._time, t)
                self.on_timer(self._time)
                self._settle(None)
            self._time = max(self._time, now)
            self.on_timer(self._time)
            self._settle(None)
            self.barrier.begin(now)
            self._settle(now)

    def close(self) -> None:
        """Stop serving and close both ends of the pseudo-terminal. Safe to call twice."""
        self._stop.set()
        if self._service is not None and self._service is not threading.current_thread():
            self._service.join(timeout=2.0)
        self.barrier.detach()
        with self._lock:
            for fd in (self._master, self._slave):
                if fd is not None:
                    with contextlib.suppress(OSError):
                        os.close(fd)
            self._master = self._slave = None

    def true_joints(self) -> np.ndarray:
        """Joint positions in the world (missed steps included), degrees / mm."""
        with self._lock:
            return self.joints.true(self._time)

    def reported_joints(self) -> np.ndarray:
        """Joint positions the firmware believes, degrees / mm."""
        with self._lock:
            return self.joints.reported(self._time)

    def halt(self, reason: str) -> None:
        """Stop the joints dead where they are (a crash, an e-stop)."""
        with self._lock:
            self.joints.halt(self._time)
            self.halted_reason = reason

    def inject(self, fault: str, **options: float) -> None:
        """Inject a fault from now on.

        * ``corrupt``: ``rate`` (probability per byte sent) and/or ``count`` (the
          next n bytes sent) get one random bit flipped;
        * ``drop``: ``rate`` and/or ``count`` bytes sent are lost;
        * ``cut``: the link goes dead; by default the device hangs up (reads fail
          as on a USB unplug), with ``silent=1`` it just stops talking and listening;
        * ``missed_steps``: ``joint`` (index) slips by ``amount`` (deg / mm) that the
          firmware does not know about.
        """
        with self._lock:
            if fault == "corrupt":
                self._corrupt_rate = float(options.get("rate", 0.0))
                self._corrupt_count += int(options.get("count", 0))
            elif fault == "drop":
                self._drop_rate = float(options.get("rate", 0.0))
                self._drop_count += int(options.get("count", 0))
            elif fault == "cut":
                if options.get("silent"):
                    # The handshake goes on: the driver then sees the run's time pass
                    # without a reply and finds the link lost at the same tick every run.
                    self._silent = True
                else:
                    self.barrier.detach()
                    self._hang_up()
            elif fault == "missed_steps":
                self.joints.miss_steps(int(options.get("joint", 0)), float(options["amount"]))
            else:
                raise ValueError(
                    f"{type(self).__name__}: unknown fault {fault!r} (known: {', '.join(FAULTS)})"
                )

    # ------------------------------------------------------------------ I/O for subclasses

    def send(self, data: bytes) -> None:
        """Send bytes to the host, through the injected faults; lost if nobody reads."""
        if self._master is None or self._silent or not data:
            return
        data = self._apply_faults(data)
        if not data:
            return
        try:
            n = os.write(self._master, data)
        except (BlockingIOError, OSError):
            return
        self.barrier.sent(n)
        self._record("tx", bytes(data[:n]))

    # ------------------------------------------------------------------ internals

    def _record(self, direction: str, data: bytes) -> None:
        # The pty may split one write into several reads; bytes of one direction at
        # one instant are merged so the transcript does not depend on that.
        if self.transcript:
            t, last_dir, last = self.transcript[-1]
            if t == self._time and last_dir == direction:
                self.transcript[-1] = (t, direction, last + data)
                return
        self.transcript.append((self._time, direction, data))

    def _apply_faults(self, data: bytes) -> bytes:
        if not (self._corrupt_rate or self._corrupt_count or self._drop_rate or self._drop_count):
            return data
        out = bytearray()
        for byte in data:
            if self._drop_count > 0:
                self._drop_count -= 1
                continue
            if self._drop_rate and self._rng.random() < self._drop_rate:
                continue
            if self._corrupt_count > 0 or (
                self._corrupt_rate and self._rng.random() < self._corrupt_rate
            ):
                self._corrupt_count = max(0, self._corrupt_count - 1)
                byte ^= 1 << int(self._rng.integers(8))
            out.append(byte)
        return bytes(out)

    def _read_available(self) -> bytes | None:
        """Data the host wrote (``b""`` after a control report), or None when nothing is there."""
        if self._master is None:
            return None
        try:
            chunk = os.read(self._master, 4096)
        except (BlockingIOError, OSError):
            return None
        if not chunk:
            return None
        if not self._packet:
            return chunk
        control, data = parse_packet(chunk)
        if control & TIOCPKT_FLUSHREAD:
            self.port_opens += 1
            self.on_port_opened(self._time)
        return data

    def _pump_input(self, complete: bool) -> None:
        """Read and handle what the host wrote; with ``complete``, wait for every byte it wrote."""
        deadline = time.monotonic() + self.barrier.timeout
        while True:
            data = self._read_available()
            if data is not None:
                if not data:
                    continue  # a control report: data may follow at once
                self.barrier.received(len(data))
                if not self._silent:
                    self._record("rx", data)
                    self.on_bytes(data, self._time)
                if complete and self.barrier.attached and self.barrier.missing() == 0:
                    # Every byte the caught-up driver wrote is in: a read for more would
                    # only find the port empty.
                    return
                continue
            if not complete or self.barrier.missing() == 0 or time.monotonic() > deadline:
                return
            if self._master is None:
                return  # a handler hung up the port: nothing more will arrive on it
            select.select([self._master], [], [], 0.05)

    def _settle(self, tick: float | None) -> None:
        while True:
            if not self.barrier.wait_driver(tick):
                self._pump_input(complete=False)
                return
            if self.barrier.missing() == 0:
                return
            self._pump_input(complete=True)

    def _hang_up(self) -> None:
        for fd in (self._master, self._slave):
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = None

    def _serve(self) -> None:
        while not self._stop.is_set():
            master = self._master
            if master is None:
                return
            wait = self.service_period
            nxt = self.next_event_time()
            if nxt is not None:
                wait = min(wait, max(0.0, nxt - self.clock.now()))
            with contextlib.suppress(OSError, ValueError):
                select.select([master], [], [], wait)
            if self._stop.is_set():
                return
            self.step(self.clock.now())


def _packet_mode(master: int) -> bool:
    """Put pty master ``master`` in packet mode; False where the platform has none."""
    if _TIOCPKT is None:
        return False
    try:
        fcntl.ioctl(master, _TIOCPKT, struct.pack("i", 1))
    except OSError:
        return False
    return True
