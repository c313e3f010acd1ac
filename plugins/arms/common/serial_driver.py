"""The threaded pyserial driver every arm driver builds on.

:class:`SerialArmDriver` opens the port (a real ``/dev/ttyUSB0`` or an
emulator's pty, the same code path), runs the serial I/O on its own thread,
watches the link, keeps the motion handles, and refuses bad targets before a
byte is sent. A subclass writes the protocol:

* :meth:`SerialArmDriver.on_data` parses received bytes (on the I/O thread);
* :meth:`SerialArmDriver.on_time` takes the actions due at a time (polls,
  retries, streaming steps), also on the I/O thread;
* :meth:`SerialArmDriver.handshake_done` says when :meth:`connect` may return;
* :meth:`SerialArmDriver.on_fault` makes the arm safe when the link fails (a
  torque-off, sent with :meth:`SerialArmDriver.write_anyway`);
* the :class:`~armtree.api.rig.ArmDriver` methods (moves, suction, stop).

It calls :meth:`SerialArmDriver.write` to send, :meth:`SerialArmDriver.mark_alive`
when a valid frame or reply arrives, and :meth:`SerialArmDriver.lose_link`
when the arm stops making sense. Times are seconds on the run's clock; on a
virtual clock "now" is the tick the emulator announced (see ``barrier``).
"""

from __future__ import annotations

import contextlib
import errno
import math
import os
import stat
import threading
import time
from collections.abc import Callable

import numpy as np
import serial

from armtree.api.clock import Clock
from armtree.api.rig import ArmDriver, MotionHandle, MotionStatus
from armtree.errors import HardwareFault, Unreachable
from armtree.maths.motion.kinematics import KinematicModel

from .barrier import StepBarrier
from .checks import check_joint_target, check_position_target
from .framing import identify_foreign_protocol


def _no_interrupt(reason: str, fault: HardwareFault | None = None) -> None:
    """The interrupt of a driver made without a run: nothing to halt."""


def open_serial_port(port: str, baud: int, read_timeout: float = 0.01) -> serial.Serial:
    """Open ``port`` exclusively at ``baud`` (8N1), or raise a :class:`HardwareFault` saying why."""
    if not os.path.exists(port):
        raise HardwareFault(
            "no such serial port (is the arm plugged in and powered? "
            "use 'port: sim' for the simulation)",
            port,
        )
    kind = _not_a_tty(port)
    if kind:
        raise HardwareFault(
            f"not a serial port: it is {kind}; expected the arm's serial device "
            "(/dev/ttyUSB0, /dev/ttyACM0; `armtree detect-port` lists them)",
            port,
        )
    ser = serial.Serial()
    ser.port = port
    ser.baudrate = baud
    ser.bytesize = serial.EIGHTBITS
    ser.parity = serial.PARITY_NONE
    ser.stopbits = serial.STOPBITS_ONE
    ser.timeout = read_timeout
    ser.write_timeout = 1.0
    ser.exclusive = True
    try:
        ser.open()
    except serial.SerialException as exc:
        text = str(exc)
        code = getattr(exc, "errno", None)
        if "exclusively lock" in text or code in (errno.EBUSY, errno.EAGAIN):
            raise HardwareFault("port is busy: another program has it open", port) from exc
        if code == errno.EACCES or "Permission denied" in text:
            raise HardwareFault(
                "permission denied (on Linux, add yourself to the 'dialout' group)", port
            ) from exc
        if code == errno.ENOENT:
            raise HardwareFault("no such serial port", port) from exc
        if code == errno.ENOTTY or "Inappropriate ioctl" in text:
            raise HardwareFault(
                "not a serial port: a device that is not a terminal (expected the arm's "
                "serial device, e.g. /dev/ttyUSB0; `armtree detect-port` lists them)",
                port,
            ) from exc
        raise HardwareFault(f"cannot open the serial port: {text}", port) from exc
    except (OSError, ValueError) as exc:
        raise HardwareFault(f"not a serial port: {exc}", port) from exc
    return ser


def _not_a_tty(port: str) -> str | None:
    """What ``port`` is when it cannot be a serial port (a file, a directory), from its mode."""
    try:
        mode = os.stat(port).st_mode
    except OSError:
        return None  # let opening it say why
    if stat.S_ISREG(mode):
        return "a regular file"
    if stat.S_ISDIR(mode):
        return "a directory"
    if not stat.S_ISCHR(mode):
        return "not a character device"
    return None


#: How often a flush interrupted by a signal is tried again before the link counts as lost.
FLUSH_TRIES = 5
#: Wall seconds :meth:`SerialArmDriver.write_anyway` may wait for the port and for its bytes
#: to leave: a stop on the way out is tried, never waited on.
WRITE_ANYWAY_S = 0.2
#: A gap this long between two turns of the I/O thread (wall seconds; a turn takes about
#: the port's 10 ms read timeout) means the process was suspended or the machine slept.
PAUSE_S = 0.5

try:
    import termios

    _DRAIN_ERRORS: tuple[type[BaseException], ...] = (termios.error,)
except ImportError:  # Windows: pyserial's flush does not drain through termios
    _DRAIN_ERRORS = ()


def _flush(ser: serial.Serial) -> None:
    """Wait until ``ser`` has sent what was written.

    pyserial's POSIX flush is ``termios.tcdrain``, which a signal (Ctrl-C landing on
    the driver's thread) interrupts with ``termios.error``, not an ``OSError``, and
    which Python does not retry; the run then ended as a lost link (exit 3) instead
    of an interrupt (130). An interrupted drain is tried again; any other
    ``termios.error`` is raised as the ``OSError`` it is.
    """
    for attempt in range(FLUSH_TRIES):
        try:
            ser.flush()
            return
        except _DRAIN_ERRORS as exc:
            code = exc.args[0] if exc.args and isinstance(exc.args[0], int) else errno.EIO
            if code != errno.EINTR or attempt == FLUSH_TRIES - 1:
                raise OSError(code, os.strerror(code)) from exc


class SerialArmDriver(ArmDriver):
    """A serial arm driver with its I/O thread; see the module docstring for the contract.

    ``barrier`` and ``pump`` are given only when the driver talks to an
    in-process emulator on a virtual clock: the barrier makes the exchange
    deterministic and ``pump(now)`` (the emulator's ``step``) lets
    :meth:`connect` make the emulator boot. ``interrupt(reason, fault)`` is the
    run's interrupt, called when the link is lost. ``link_timeout`` is how long
    (run-clock seconds) the arm may stay silent once connected;
    ``connect_timeout`` (wall seconds) bounds :meth:`connect`.
    """

    #: Human name of the protocol, for error messages ("Dobot V1.0 status frames").
    protocol = "the arm's protocol"

    def __init__(
        self,
        model: KinematicModel,
        port: str,
        *,
        baud: int,
        clock: Clock,
        barrier: StepBarrier | None = None,
        pump: Callable[[float], None] | None = None,
        interrupt: Callable[[str, HardwareFault | None], None] | None = None,
        link_timeout: float = 1.0,
        connect_timeout: float = 3.0,
    ) -> None:
        self.model = model
        self.device = port
        self.baud = baud
        self.clock = clock
        self.barrier = barrier
        self.pump = pump
        self.interrupt = interrupt or _no_interrupt
        self.link_timeout = link_timeout
        self.connect_timeout = connect_timeout
        #: Wall time (``time.perf_counter``) of the newest write, for latency figures.
        self.last_write_wall = 0.0
        self._ser: serial.Serial | None = None
        self._thread: threading.Thread | None = None
        self._running = threading.Event()
        self._write_lock = threading.Lock()
        self._state_lock = threading.RLock()
        self._fault: HardwareFault | None = None
        self._connected = False
        self._reopening = False
        self._seen = bytearray()
        self._now = -math.inf
        self._last_alive = -math.inf
        self._handles: list[MotionHandle] = []
        self._last_sent: object = None
        self._stop_requested = threading.Event()
        #: (run time, wall seconds) of each pause of the process the I/O thread noticed.
        self.pauses: list[tuple[float, float]] = []
        self._pauses_taken = 0
        self._last_turn = _awake_time()

    # ------------------------------------------------------------------ subclass hooks

    def on_data(self, data: bytes) -> None:
        """Handle received bytes (I/O thread)."""
        raise HardwareFault(f"{type(self).__name__} does not read the port", self.device)

    def on_time(self, now: float) -> None:  # noqa: B027 - protocols without timed actions
        """Take the actions due at ``now`` (I/O thread)."""

    def on_open(self) -> None:  # noqa: B027 - protocols that just listen at first
        """The port is open and the I/O thread about to start: queue the first requests."""

    def handshake_done(self) -> bool:
        """True once the arm has answered as it should; :meth:`connect` waits for it."""
        return self._last_alive > -math.inf

    def on_fault(self) -> None:  # noqa: B027 - arms with nothing to switch off
        """The link just failed, for any reason: make the arm safe (torque off), best
        effort, with :meth:`write_anyway`. Called once per fault, before the run hears of
        it, on whichever thread found it; what it raises is ignored."""

    # ------------------------------------------------------------------ helpers

    @property
    def now(self) -> float:
        """The time the I/O thread is handling (seconds on the run clock)."""
        return self._now

    @property
    def connected(self) -> bool:
        """True between a successful :meth:`connect` and :meth:`close` or a fault."""
        return self._connected and self._fault is None

    @property
    def fault(self) -> HardwareFault | None:
        """The fault that stopped the link, if any."""
        return self._fault

    def write(self, data: bytes) -> bool:
        """Send ``data`` now; False (and nothing sent) when the link is down."""
        ser = self._ser
        if ser is None or self._fault is not None:
            return False
        failed = None
        with self._write_lock:
            try:
                n = ser.write(data)
                _flush(ser)
            except (serial.SerialException, OSError) as exc:
                failed = exc
            else:
                self.last_write_wall = time.perf_counter()
                if self.barrier is not None:
                    self.barrier.wrote(n or 0)
        if failed is not None:
            # outside the write lock: losing the link writes a torque-off (on_fault)
            self.lose_link(f"link lost while writing: {failed}")
            return False
        return True

    def write_anyway(self, data: bytes, timeout: float = WRITE_ANYWAY_S) -> bool:
        """Send ``data`` even when the link has failed (a torque-off on the way out);
        True when it left. Best effort and bounded: at most ``timeout`` wall seconds for
        the port and for the bytes to drain; a port that fails is left as it is."""
        ser = self._ser
        if ser is None:
            return False
        if not self._write_lock.acquire(timeout=timeout):
            return False
        try:
            n = ser.write(data)
            # not tcdrain (flush): it has no timeout, and a device that stopped reading
            # must not hold the way out
            deadline = time.monotonic() + timeout
            while ser.out_waiting and time.monotonic() < deadline:
                time.sleep(0.001)
        except Exception:  # noqa: BLE001 - the link is already lost; nothing more to say
            return False
        finally:
            self._write_lock.release()
        self.last_write_wall = time.perf_counter()
        if self.barrier is not None:
            self.barrier.wrote(n or 0)
        return True

    def mark_alive(self) -> None:
        """A valid frame or reply arrived: the link is alive at the current time."""
        self._last_alive = self._now if math.isfinite(self._now) else self._current_time()
        if not math.isfinite(self._last_alive):
            self._last_alive = self.clock.now()

    def lose_link(self, message: str, reason: str | None = None) -> None:
        """The link is gone: record the fault, make the arm safe (:meth:`on_fault`), fail
        every motion, interrupt the run.

        ``reason`` is the interrupt's (default: ``link lost on DEVICE``); a device that
        stopped itself (an overloaded servo) names that instead.
        """
        with self._state_lock:
            if self._fault is not None:
                return
            fault = HardwareFault(message, self.device)
            self._fault = fault
            handles, self._handles = self._handles, []
        # Safe first: the arm's torque goes off before anyone is told, on every fault.
        with contextlib.suppress(Exception):
            self.on_fault()
        if self.barrier is not None:
            self.barrier.detach()
        # The run hears of the fault before any behaviour sees its motion fail, so the
        # run ends as a hardware fault (exit 3), not as the tree's failure.
        if self._connected or self._reopening:
            self.interrupt(reason or f"link lost on {self.device}", fault)
        for handle in handles:
            handle.update(MotionStatus.FAILED, error=fault)

    def track(self, handle: MotionHandle) -> MotionHandle:
        """Keep ``handle`` to be failed if the link is lost or stopped by :meth:`stop_all`."""
        with self._state_lock:
            self._handles = [h for h in self._handles if not h.done]
            self._handles.append(handle)
        return handle

    def active_handles(self) -> list[MotionHandle]:
        """Handles not yet finished, oldest first."""
        with self._state_lock:
            self._handles = [h for h in self._handles if not h.done]
            return list(self._handles)

    def busy(self) -> bool:
        """True while a tracked command has not finished."""
        return bool(self.active_handles())

    def stop_all(self) -> None:
        """Mark every unfinished handle STOPPED."""
        with self._state_lock:
            handles, self._handles = self._handles, []
        for handle in handles:
            handle.update(MotionStatus.STOPPED)

    def is_duplicate(self, key: object) -> bool:
        """True when ``key`` equals the last command sent (Showers 2016, third safeguard)."""
        return self._last_sent is not None and _same(self._last_sent, key)

    def remember_sent(self, key: object) -> None:
        """Record ``key`` as the last command sent (None forgets it)."""
        self._last_sent = key

    @staticmethod
    def refused(description: str, error: Exception) -> MotionHandle:
        """A FAILED handle for a target refused before anything was sent."""
        handle = MotionHandle(description)
        handle.update(MotionStatus.FAILED, error=error)
        return handle

    def checked_joints(self, q: np.ndarray) -> np.ndarray:
        """``q`` checked against limits and constraints; raises :class:`Unreachable`."""
        return check_joint_target(self.model, q)

    def checked_move(self, q: np.ndarray, speed: float) -> np.ndarray:
        """``q`` (degrees) for a move at ``speed`` in (0, 1], connecting first if need be.

        Raises the :class:`HardwareFault` that prevents connecting, or
        :class:`Unreachable` for a target or speed the arm cannot take.
        """
        fault = self.ensure_connected()
        if fault is not None:
            raise fault
        q = self.checked_joints(q)
        if not 0.0 < speed <= 1.0:
            raise Unreachable(f"speed {speed} is not in (0, 1]")
        return q

    def checked_position(self, xyz: np.ndarray) -> np.ndarray:
        """Joint solution for ``xyz`` nearest the reported joints; raises :class:`Unreachable`."""
        near = self.joints() if self.connected else None
        return check_position_target(self.model, xyz, near)

    def move_to(self, xyz: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Move the tool centre to ``xyz`` (mm) through host-side IK; see :meth:`move_joints`."""
        try:
            q = self.checked_position(xyz)
        except Unreachable as exc:
            return self.refused(f"move to {np.asarray(xyz).tolist()}", exc)
        return self.move_joints(q, speed)

    def request_stop(self) -> None:
        """Have the I/O thread call :meth:`stop` at its next turn; returns at once.

        For the tick watchdog, whose run thread is stuck: the stop then goes out
        from the thread that owns the port, within one read timeout.
        """
        self._stop_requested.set()
        if self._thread is None or not self._thread.is_alive():
            super().request_stop()

    def ensure_connected(self) -> HardwareFault | None:
        """Connect on first use; return the fault that prevents it, if any.

        While the port is being reopened (:meth:`reopen`) nothing is connected:
        commands wait for the arm to answer.
        """
        if self._fault is not None:
            return self._fault
        if not self._connected and not self._reopening:
            try:
                self.connect()
            except HardwareFault as exc:
                return exc
        return self._fault

    # ------------------------------------------------------------------ lifecycle

    def connect(self) -> None:
        """Open the port, start the I/O thread and wait for the arm's handshake.

        Raises :class:`HardwareFault` naming the port when it is missing or busy,
        or when the device does not speak :attr:`protocol` (a foreign banner is named).
        """
        if self._connected:
            if self._fault is not None:
                raise self._fault
            return
        self.open_link()
        deadline = time.monotonic() + self.connect_timeout
        while not self.handshake_done() and self._fault is None:
            if time.monotonic() > deadline:
                break
            if self.pump is not None and self.clock.virtual:
                self.pump(self.clock.now())
                time.sleep(0.001)
            else:
                time.sleep(0.005)
        if self.handshake_done() and self._fault is None:
            self._connected = True
            return
        fault = HardwareFault(self._no_answer_message(), self.device)
        if self._fault is not None and self._ser is not None:
            # The protocol gave up during the handshake (no reply, a bad one): say
            # what answered instead, then what the protocol noticed.
            fault = HardwareFault(f"{fault.message} ({self._fault.message})", self.device)
        elif self._fault is not None:
            fault = self._fault
        self.close()
        self._fault = fault
        raise fault

    def open_link(self) -> None:
        """Open the port and start the I/O thread, without waiting for the handshake.

        :meth:`connect` waits for :meth:`handshake_done` after it; a driver that
        reopens its port while the run goes on (a board reset) waits tick by
        tick instead. Raises :class:`HardwareFault` naming the port when it
        cannot be opened.
        """
        self._fault = None
        self._seen.clear()
        self._last_alive = -math.inf
        self._ser = open_serial_port(self.device, self.baud)
        self._running.set()
        if self.barrier is not None:
            self.barrier.attach(wake=self._wake)
        self.on_open()
        self._thread = threading.Thread(
            target=self._loop, name=f"serial {self.device}", daemon=True
        )
        self._thread.start()

    def reopen(self) -> None:
        """Close the port and open it again at once, without waiting for the arm.

        A board that resets when its port is opened (an Arduino) reboots. Until
        :meth:`reopened` is True the link is not connected but not lost either:
        commands wait, and the caller bounds the wait. Raises
        :class:`HardwareFault` naming the port when it cannot be opened again.
        """
        self.close()
        self._reopening = True
        try:
            self.open_link()
        except HardwareFault as exc:
            self._reopening = False
            self._fault = exc
            raise

    def reopened(self) -> bool:
        """After :meth:`reopen`: True (and connected again) once the handshake is done."""
        if self._reopening and self._fault is None and self.handshake_done():
            self._reopening = False
            self._connected = True
        return self._connected and self._fault is None

    def close(self) -> None:
        """Stop the I/O thread and release the port. Safe to call twice."""
        self._reopening = False
        self._running.clear()
        if self.barrier is not None:
            self.barrier.detach()
        ser = self._ser
        if ser is not None:
            with contextlib.suppress(Exception):
                ser.cancel_read()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self._thread = None
        if ser is not None:
            with contextlib.suppress(Exception):
                ser.close()
        self._ser = None
        self._connected = False
        self.stop_all()

    # ------------------------------------------------------------------ internals

    def _no_answer_message(self) -> str:
        seen = bytes(self._seen)
        foreign = identify_foreign_protocol(seen)
        if foreign:
            return f"wrong protocol: expected {self.protocol}, but the device looks like {foreign}"
        if seen:
            return (
                f"wrong protocol: expected {self.protocol}, got {len(seen)} bytes that are not "
                f"(first: {seen[:16].hex(' ')}); check the firmware and the baud rate ({self.baud})"
            )
        return (
            f"no answer: expected {self.protocol} within {self.connect_timeout:g} s "
            f"(is the arm powered, the firmware right and the baud rate {self.baud}?)"
        )

    def _resume_after_pause(self, gap: float) -> None:
        """The I/O thread did not run for ``gap`` wall seconds: the process was suspended
        (SIGSTOP, Ctrl-Z) or the machine slept, while the arm went on. What waits in the
        port's buffer was sent before and during the pause, so the arm's state is read
        again: the plausibility guard takes the next readings as its new reference (no
        jump is held against them) and needs its stable streak again, and the silence is
        not held against the link. Replies waiting there are still handled. The pause is
        kept in :attr:`pauses`."""
        guard = getattr(self, "guard", None)
        if guard is not None:
            guard.resync(self._now)
        if math.isfinite(self._last_alive):
            self._last_alive = self._now
        with self._state_lock:
            self.pauses.append((self._now, gap))

    def suspended_s(self, since: float) -> float:
        """Wall seconds of the pauses :meth:`_resume_after_pause` noticed after clock time ``since``."""
        with self._state_lock:
            return sum(gap for at, gap in self.pauses if at > since)

    def take_pauses(self) -> list[tuple[float, float]]:
        """The pauses (clock time noticed, wall seconds) not taken before, oldest first:
        the run reports each once, from its own thread."""
        with self._state_lock:
            fresh = self.pauses[self._pauses_taken :]
            self._pauses_taken = len(self.pauses)
        return fresh

    def _wake(self) -> None:
        ser = self._ser
        if ser is not None:
            with contextlib.suppress(Exception):
                ser.cancel_read()

    def _current_time(self) -> float:
        # With a barrier, time moves only when the emulator announces a tick, so the
        # driver's timed actions happen at the same point of the exchange every run.
        if self.barrier is not None and self.barrier.attached:
            return self.barrier.tick
        return self.clock.now()

    def _loop(self) -> None:
        while self._running.is_set() and self._fault is None:
            ser = self._ser
            if ser is None:
                return
            try:
                # Block for the first byte, then take what else came with it: a reply arrives
                # in one burst and is handled in one turn, and between telling the emulator
                # it may go on and sleeping this thread makes no other system call.
                data = ser.read(1)
                if data:
                    waiting = ser.in_waiting
                    if waiting:
                        data += ser.read(waiting)
            except (serial.SerialException, OSError, TypeError) as exc:
                if self._running.is_set():
                    self.lose_link(f"link lost: {exc}")
                return
            self._now = self._current_time()
            awake = _awake_time()
            gap, self._last_turn = awake - self._last_turn, awake
            if gap > PAUSE_S and self.barrier is None and not self.clock.virtual:
                self._resume_after_pause(gap)
            if self._stop_requested.is_set():
                self._stop_requested.clear()
                with contextlib.suppress(Exception):
                    self.stop()
            try:
                if data:
                    if len(self._seen) < 512:
                        self._seen.extend(data[: 512 - len(self._seen)])
                    self.on_data(data)
                if self._fault is None and math.isfinite(self._now):
                    self.on_time(self._now)
            except Exception as exc:  # noqa: BLE001 - a protocol bug must stop the arm, not hang it
                self.lose_link(f"driver error ({type(exc).__name__}: {exc}); link closed")
                return
            if self._fault is not None:
                return
            if (
                self._connected
                and math.isfinite(self._last_alive)
                and self._now - self._last_alive > self.link_timeout
            ):
                self.lose_link(
                    f"link lost: no {self.protocol} for {self._now - self._last_alive:.2f} s"
                )
                return
            if self.barrier is not None:
                self.barrier.handled(len(data), self._now)


def _awake_time() -> float:
    """Seconds on a clock that runs on while the process is stopped and while the machine
    sleeps (Linux's CLOCK_BOOTTIME; elsewhere the monotonic clock)."""
    boottime = getattr(time, "CLOCK_BOOTTIME", None)
    return time.clock_gettime(boottime) if boottime is not None else time.monotonic()


def _same(a: object, b: object) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        try:
            return bool(np.array_equal(np.asarray(a), np.asarray(b)))
        except (TypeError, ValueError):
            return False
    return a == b
