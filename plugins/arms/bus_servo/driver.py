"""Driver of an arm of serial bus servos (Feetech STS or Dynamixel 2.0) on one bus.

The bus is half-duplex: the host sends one instruction and waits for the status
packets it earns before the next, so the driver keeps one request outstanding
(:class:`_Request`) and a queue behind it, on its I/O thread.

**Connecting** (:meth:`BusServoDriver.on_open`, a script of requests): ping every
configured id (a servo that does not answer, after the retry budget, or answers
as another model, is a :class:`~armtree.HardwareFault` naming its id: exit 3);
torque off; each calibrated servo's homing offset read and written when it
differs (Dynamixel: and its drive mode set to a time-based profile); the
present positions read, the goals set to them, torque on. Only then is the
arm connected.

**Running**: every ``poll_period`` a sync read of each servo's present position
(with load, voltage and temperature where the control table has them next to
it) and, when one is due, the set point of the trajectory being followed as one
sync write before it. Motion is the SSC-32's: the host times a cubic or quintic
trajectory within the joints' limits, validated before a byte is sent
(:func:`~armtree.plugins.arms.common.streaming.timed_path`), and sends a set
point every ``stream_period`` with the speed (Feetech, counts a second) or the
time (Dynamixel, ms) that brings every servo there together.

**Faults**: a status packet that does not come within ``reply_timeout`` is asked
for again, up to ``retries`` more times, and counted (:attr:`lost_status`);
past the budget the link is lost naming the servo. A status packet reporting
overload, overheat, over-current, a voltage or sensor error (Dynamixel: its
alert bit, then Hardware Error Status read) stops the arm: torque off on every
servo, a fault naming the servo and the cause (exit 3). Every fault, whatever
found it (a servo gone silent, implausible readings, a driver error, a dead port),
and every close sends the torque-off sync write past the faulted link's refusal to
write (:meth:`BusServoDriver.on_fault`; tried once, bounded, never waited on). Units: degrees at the interface, counts on the bus;
seconds on the run's clock (wall seconds while connecting).
"""

from __future__ import annotations

import collections
import math
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np

from armtree.api.rig import MotionHandle, MotionStatus, ToolState
from armtree.errors import HardwareFault, PlanningError, Unreachable
from armtree.maths.motion.collision import CollisionChecker
from armtree.maths.motion.scene import Scene
from armtree.maths.motion.trajectory import Trajectory
from armtree.maths.motion.urdf import UrdfModel
from armtree.plugins.arms.common.plausibility import StatusGuard
from armtree.plugins.arms.common.serial_driver import SerialArmDriver
from armtree.plugins.arms.common.streaming import TrajectoryStream, timed_path

from . import dynamixel, feetech
from .bus import Packet, PacketReader, decode_value, encode_value, ids_text
from .spec import ArmSpec, ServoLink
from .tables import TIME_BASED_PROFILE, ServoModel, model_name, protocol_for

#: One count of a servo's encoder, degrees.
COUNT_DEG = 360.0 / 4096
#: Counts a servo may stay from its goal and still be there.
ARRIVED_COUNTS = 3
#: Seconds past a move's end a servo may take to arrive before the move fails.
SETTLE_S = 1.0
#: Wall seconds a reply may take while connecting (the run's clock may not move then).
SETUP_TIMEOUT_S = 0.15
SIM_SETUP_TIMEOUT_S = 0.4
#: Polls between reads of the voltage and temperature, where they are read apart.
HEALTH_EVERY = 10
#: How fast the gripper servo turns, degrees a second.
GRIP_SPEED_DEG_S = 120.0
#: Ways the driver times a motion (``arm.trajectory``).
TRAJECTORY_KINDS = ("cubic", "quintic")


def _time_based(drive_mode: int) -> int | None:
    """A Dynamixel's Drive Mode with the time-based profile bit set; None when it is."""
    return None if drive_mode & TIME_BASED_PROFILE else drive_mode | TIME_BASED_PROFILE


@dataclass
class ServoState:
    """What a servo last reported: present position (counts), load (per mille of its
    rated torque, signed), supply (V) and temperature (deg C); None until read."""

    present: int | None = None
    load: int | None = None
    volts: float | None = None
    temperature: int | None = None


@dataclass
class _Request:
    """One instruction on the bus and the servos whose status packets it waits for.

    ``packet(ids)`` builds it for the servos still missing (a retry asks only them).
    """

    what: str
    ids: list[int]
    packet: Callable[[list[int]], bytes]
    on_reply: Callable[[Packet], object] | None = None
    #: Data bytes each awaited status packet carries (None: any); a packet of another
    #: size is a late answer to an earlier request, not this one's.
    size: int | None = None
    waiting: list[int] = field(default_factory=list)
    attempts: int = 0
    sent_at: float = -math.inf
    sent_wall: float = -math.inf
    first_at: float = -math.inf
    first_wall: float = -math.inf


@dataclass
class _Move:
    """A motion whose last set point went out: done when the servos are there."""

    handle: MotionHandle
    goal: dict[int, int]
    due: float
    start: np.ndarray
    target: np.ndarray


@dataclass
class _Stream:
    """A trajectory being followed; its set points are timed from the poll that sends the
    first (``stream`` is made then)."""

    handle: MotionHandle
    trajectory: Trajectory
    start: np.ndarray
    stream: TrajectoryStream | None = None


class BusServoDriver(SerialArmDriver):
    """An arm of bus servos ``spec`` describes, with URDF ``model``; see the module docstring.

    ``trajectory`` is ``"cubic"`` (Pozzani 2023, eq. 2) or ``"quintic"``; ``checker``
    validates trajectories against the profile's obstacles (default: the arm itself).
    """

    def __init__(
        self,
        model: UrdfModel,
        port: str,
        spec: ArmSpec,
        *,
        trajectory: str = "cubic",
        stream_period: float = 0.05,
        poll_period: float = 0.02,
        reply_timeout: float = 0.05,
        retries: int = 3,
        checker: CollisionChecker | None = None,
        hold: bool = True,
        **options,
    ) -> None:
        options.setdefault("baud", spec.baud)
        super().__init__(model, port, **options)
        if trajectory not in TRAJECTORY_KINDS:
            raise ValueError(f"trajectory must be one of {TRAJECTORY_KINDS}, got {trajectory!r}")
        self.model: UrdfModel = model
        self.spec = spec
        self.codec = protocol_for(spec.bus)
        self.protocol = f"{spec.bus} servos (ids {ids_text(spec.ids)}) answering pings"
        self.interpolates = False
        #: What the skills grip with: the gripper, when the arm has one.
        self.tool_kind = "gripper" if spec.gripper is not None else "suction"
        self.trajectory_kind = trajectory
        self.stream_period = float(stream_period)
        self.poll_period = float(poll_period)
        self.reply_timeout = float(reply_timeout)
        self.retries = int(retries)
        self.checker = checker or CollisionChecker(model, Scene())
        #: False: connect leaves torque off (the arm limp, to be moved by hand).
        self.hold = hold
        #: Doubts the joint angles read back (finite, limits, speed).
        self.guard = StatusGuard(model)
        #: Status packets that did not come when asked (each asked again, within the budget).
        self.lost_status = 0
        #: Ids of the servos that have answered since the port opened.
        self.servos_heard: set[int] = set()
        #: Every servo's last report, by id.
        self.servos: dict[int, ServoState] = {i: ServoState() for i in spec.ids}
        #: The newest trajectory followed and its start on the run clock (s).
        self.last_trajectory: tuple[float, Trajectory] | None = None
        self._lock = threading.RLock()
        self._reader = PacketReader(self.codec, status=True)
        self._queue: collections.deque[_Request] = collections.deque()
        self._current: _Request | None = None
        self._script: Iterator[_Request] | None = None
        self._ready = False
        self._probing = False
        self._torque_on = False
        self._setup_error: str | None = None
        self._next_poll = -math.inf
        self._acted_at = -math.inf
        self._heard = False
        self._polls = 0
        self._goals: dict[int, int] = {}
        self._stream: _Stream | None = None
        self._moves: list[_Move] = []
        self._gripper_goal: float | None = None
        self._last_handle: MotionHandle | None = None
        self._model_of = {s.id: s.model for s in spec.links}
        self._joint_of = {s.id: s.joint for s in spec.links}
        first = spec.links[0].model
        self._status_span = (
            first.span("present_position", "present_temperature")
            if spec.bus == "feetech"
            else first.span("present_load", "present_position")
        )
        self._goal_span = first.span(
            *(
                ("goal_position", "goal_velocity")
                if spec.bus == "feetech"
                else ("goal_velocity", "goal_position")
            )
        )

    # ------------------------------------------------------------------ serial hooks

    def on_open(self) -> None:
        """Start the connect script: pings, model numbers, offsets, positions, torque on."""
        with self._lock:
            self._reader.reset()
            self._queue.clear()
            self._current = None
            self._ready = False
            self._setup_error = None
            self.servos_heard.clear()
            self.guard.reset()
            self._script = self._setup()

    def handshake_done(self) -> bool:
        """True once every servo answered, was set up and holds its position."""
        return self._ready

    def on_data(self, data: bytes) -> None:
        """Status packets: to the request waiting for them; anything else is noise."""
        with self._lock:
            self._heard = True
            for packet in self._reader.feed(data):
                request = self._current
                if not packet.is_status or request is None or packet.id not in request.waiting:
                    continue
                if request.size is not None and len(packet.params) != request.size:
                    continue
                request.waiting.remove(packet.id)
                self.servos_heard.add(packet.id)
                self.mark_alive()
                if packet.error and self._status_error(packet):
                    return
                if request.on_reply is not None:
                    request.on_reply(packet)
                if self._setup_error is not None:
                    return

    def on_time(self, now: float) -> None:
        """Retry or give up a late reply, poll when due, send what is next in line."""
        failure = None
        with self._lock:
            # On a virtual clock only a new tick or a reply moves the bus, never a read
            # timing out between ticks: two runs of one seed send the same bytes.
            stepped = self.barrier is not None and self.barrier.attached
            if self._ready and stepped and now == self._acted_at and not self._heard:
                return
            self._acted_at, self._heard = now, False
            out = bytearray()
            request = self._current
            if request is not None and request.waiting and self._late(request, now):
                self.lost_status += len(request.waiting)
                if self._given_up(request, now):
                    failure = self._silent(request, now)  # lose_link turns torque off
                else:
                    out += self._send(request, now)
            if request is not None and not request.waiting:
                self._current = None
            if failure is None and self._setup_error is None:
                self._progress(now)
                if (
                    self._ready
                    and not self._queue
                    and self._current is None
                    and now >= self._next_poll
                ):
                    self._next_poll = now + self.poll_period
                    self._poll(now)
                while self._current is None and self._queue:
                    request = self._queue.popleft()
                    out += self._send(request, now)
                    if request.waiting:
                        self._current = request
        if out:
            self.write(bytes(out))
        if failure is not None:
            self.lose_link(failure)
        elif self._setup_error is not None and self._fault is None:
            self.lose_link(self._setup_error)

    def _send(self, request: _Request, now: float) -> bytes:
        """The request's bytes: first to every servo it asks, then to those still silent."""
        if request.attempts == 0:
            request.waiting = list(request.ids)
            request.first_at, request.first_wall = now, time.monotonic()
        request.attempts += 1
        request.sent_at, request.sent_wall = now, time.monotonic()
        return request.packet(list(request.waiting))

    def _late(self, request: _Request, now: float) -> bool:
        if not self._ready:
            # an emulator stepped with the run (a barrier) answers as soon as it is pumped:
            # what has not come by then is lost, unless the machine is very busy
            wait = SIM_SETUP_TIMEOUT_S if self.barrier is not None else SETUP_TIMEOUT_S
            return time.monotonic() - request.sent_wall >= max(self.reply_timeout, wait)
        return now - request.sent_at >= self.reply_timeout - 1e-9

    def _given_up(self, request: _Request, now: float) -> bool:
        """The retry budget is spent: ``retries`` more asks and at least ``link_timeout`` of
        silence (a host stalled for a moment is not a servo gone; while connecting, at
        most half the time connecting may take)."""
        if request.attempts <= self.retries:
            return False
        if not self._ready:
            wait = min(self.link_timeout, 0.5 * self.connect_timeout)
            return time.monotonic() - request.first_wall >= wait
        return now - request.first_at >= self.link_timeout - 1e-9

    def _silent(self, request: _Request, now: float) -> str:
        names = ", ".join(f"{i} ({self._joint_of.get(i, '?')})" for i in request.waiting)
        servo = "servo" if len(request.waiting) == 1 else "servos"
        since = time.monotonic() - request.first_wall if not self._ready else now - request.first_at
        return (
            f"{servo} {names} did not answer {request.what} in {request.attempts} asks over "
            f"{since:.2f} s ({self.lost_status} status packets lost in all): check the servo's "
            f"cable, power and id, and the baud rate ({self.baud:,})"
        )

    def _no_answer_message(self) -> str:
        if self._setup_error is not None or self._fault is not None:
            return f"the {self.spec.bus} servos did not all come up as configured"
        request = self._current
        if request is not None and request.waiting and self.servos_heard:
            names = ", ".join(f"{i} ({self._joint_of.get(i, '?')})" for i in request.waiting)
            return (
                f"the {self.spec.bus} servos did not all come up within "
                f"{self.connect_timeout:g} s: {names} still silent to {request.what} "
                f"(the others answered): check the servo's cable, power and id"
            )
        return super()._no_answer_message()

    # ------------------------------------------------------------------ connecting

    def _setup(self) -> Iterator[_Request]:
        """The requests that bring the bus up, each after the one before has its answers."""
        codec, ids = self.codec, self.spec.ids
        for servo_id in ids:

            def ping(waiting: list[int], i: int = servo_id) -> bytes:
                return codec.ping(i)

            yield _Request(
                "a ping", [servo_id], ping, self._on_ping, size=len(codec.ping_reply(0, 0))
            )
        if self.spec.bus == "feetech":  # a Feetech ping carries no model number
            address, size = self.spec.links[0].model.span("model_number", "model_number")
            yield _Request(
                "a read of its model number",
                ids,
                lambda w: codec.sync_read(address, size, w),
                lambda p: self._check_model(p.id, decode_value(p.params, None)),
                size=size,
            )
        if self._probing:
            return
        yield self._write_all("torque_enable", 0)
        if self.spec.bus == "feetech":
            yield self._write_all("lock", 0)
        for link in self.spec.links:
            offset = link.calibration.homing_offset
            if link.calibrated:

                def homing(value: int, o: int = offset) -> int | None:
                    return None if value == o else o

                yield from self._ensure(link, "homing_offset", homing)
            if self.spec.bus == "dynamixel":
                yield from self._ensure(link, "drive_mode", _time_based)
        yield self._status_read()
        if self.hold:
            yield self._hold_here()
            self._torque_on = True
            yield self._write_all("torque_enable", 1)
            if self.spec.bus == "feetech":
                yield self._write_all("lock", 1)

    def _progress(self, now: float) -> None:
        """Take the connect script's next request when the bus is free."""
        if self._script is None or self._current is not None or self._queue:
            return
        try:
            self._queue.append(next(self._script))
        except StopIteration:
            self._script = None
            self._ready = True
            self._next_poll = now

    def _on_ping(self, packet: Packet) -> None:
        if self.spec.bus == "dynamixel" and len(packet.params) >= 2:
            self._check_model(packet.id, int.from_bytes(packet.params[:2], "little"))

    def _check_model(self, servo_id: int, number: int) -> None:
        expected = self._model_of[servo_id]
        if number != expected.number:
            self._setup_error = (
                f"servo {servo_id} ({self._joint_of[servo_id]}) is a {model_name(number)}, "
                f"expected a {model_name(expected.number)}: check its id, or set "
                f"arm.servos.{self._joint_of[servo_id]}.model"
            )

    def _ensure(
        self, link: ServoLink, register: str, wanted: Callable[[int], int | None]
    ) -> Iterator[_Request]:
        """Read ``register`` of ``link``'s servo, then write ``wanted(value)`` to it unless
        that is None (the register already holds what it should)."""
        reg = link.model.register(register)
        found: list[int] = []
        yield _Request(
            f"a read of its {register}",
            [link.id],
            lambda w: self.codec.read(link.id, reg.address, reg.size),
            lambda p: found.append(decode_value(p.params, reg.encoding, self.codec.byteorder)),
            size=reg.size,
        )
        value = wanted(found[0]) if found else None
        if value is not None:
            data = encode_value(value, reg.size, reg.encoding, self.codec.byteorder)
            yield _Request(
                f"the write of its {register}",
                [link.id],
                lambda w: self.codec.write(link.id, reg.address, data),
                size=0,
            )

    def _write_all(self, register: str, value: int) -> _Request:
        """A sync write of ``register`` = ``value`` on every servo (nobody answers)."""
        reg = self.spec.links[0].model.register(register)
        data = {
            i: encode_value(value, reg.size, reg.encoding, self.codec.byteorder)
            for i in self.spec.ids
        }
        return _Request(
            f"{register} {value}", [], lambda w: self.codec.sync_write(reg.address, reg.size, data)
        )

    def _hold_here(self) -> _Request:
        """Goals where the servos are (so torque on moves nothing), at full speed."""
        goals = {i: s.present for i, s in self.servos.items() if s.present is not None}
        self._goals = dict(goals)
        return self._goal_request(goals)

    # ------------------------------------------------------------------ running

    def _poll(self, now: float) -> None:
        """Queue the set point due (if any) and the read of every servo's state."""
        goals, timing = self._stream_step(now)
        if self._gripper_goal is not None and self.spec.gripper is not None:
            link = self.spec.gripper
            counts = int(round(float(link.calibration.counts(self._gripper_goal))))
            if self._goals.get(link.id) != counts:
                goals[link.id] = counts
                timing[link.id] = self._grip_time(link, counts)
        if goals:
            speeds = {i: self._speed(i, c, timing.get(i, 0.0)) for i, c in goals.items()}
            self._goals.update(goals)
            self._queue.append(self._goal_request(goals, speeds))
        self._queue.append(self._status_read())
        self._polls += 1
        if self.spec.bus == "dynamixel" and self._polls % HEALTH_EVERY == 0:
            self._queue.append(self._health_read())

    def _speed(self, servo_id: int, counts: int, seconds: float) -> int:
        """The speed register that brings a servo from its last goal to ``counts`` in
        ``seconds``: Feetech counts a second, Dynamixel (time-based profile) milliseconds;
        0 (as fast as it turns) when there is no time to keep."""
        if seconds <= 0:
            return 0
        if self.spec.bus == "dynamixel":
            return max(1, int(round(seconds * 1000.0)))
        # from the last goal, or from where it was last read when it lags behind that (a set
        # point sent early on a busy host): a servo never crawls the last counts home
        present = self.servos[servo_id].present
        distance = max(
            abs(counts - self._goals.get(servo_id, counts)),
            0 if present is None else abs(counts - present),
        )
        if distance == 0:
            return 0
        # a servo far from its goal (knocked, or read wrong) asks more than the register
        # holds: as fast as it goes, not a driver error
        sign_bit = self._model_of[servo_id].register("goal_velocity").encoding
        if sign_bit is None:  # Feetech's speed is sign-magnitude
            raise TypeError("a Feetech goal_velocity register without its sign bit")
        top = (1 << sign_bit) - 1
        return min(top, max(1, int(round(distance / seconds))))

    def _goal_request(
        self, goals: dict[int, int], speeds: dict[int, int] | None = None
    ) -> _Request:
        """One sync write of each servo's goal and its speed register (:meth:`_speed`)."""
        address, length = self._goal_span
        speeds = speeds or {}
        data = {
            i: self._goal_bytes(self._model_of[i], c, speeds.get(i, 0)) for i, c in goals.items()
        }
        return _Request(
            "goal positions", [], lambda w: self.codec.sync_write(address, length, data)
        )

    def _goal_bytes(self, model: ServoModel, counts: int, speed: int) -> bytes:
        """The goal span's bytes: the position and the speed register."""
        address, length = self._goal_span
        out = bytearray(length)
        for name, value in (("goal_position", counts), ("goal_velocity", speed)):
            reg = model.register(name)
            at = reg.address - address
            out[at : at + reg.size] = encode_value(
                value, reg.size, reg.encoding, self.codec.byteorder
            )
        return bytes(out)

    def _status_read(self) -> _Request:
        address, length = self._status_span
        return _Request(
            "the read of its present position",
            list(self.spec.ids),
            lambda w: self.codec.sync_read(address, length, w),
            self._on_status,
            size=length,
        )

    def _health_read(self) -> _Request:
        address, length = self.spec.links[0].model.span("present_voltage", "present_temperature")
        return _Request(
            "the read of its voltage and temperature",
            list(self.spec.ids),
            lambda w: self.codec.sync_read(address, length, w),
            lambda p: self._store(p, address),
            size=length,
        )

    def _on_status(self, packet: Packet) -> None:
        self._store(packet, self._status_span[0])
        request = self._current
        if request is not None and not request.waiting and self._ready:
            self._arrived()

    def _store(self, packet: Packet, address: int) -> None:
        """Keep the registers a status packet carries (from ``address`` on)."""
        model = self._model_of[packet.id]
        state = self.servos[packet.id]
        for name in ("present_position", "present_load", "present_voltage", "present_temperature"):
            reg = model.register(name)
            at = reg.address - address
            if at >= 0 and at + reg.size <= len(packet.params):
                value = decode_value(
                    packet.params[at : at + reg.size], reg.encoding, self.codec.byteorder
                )
                if name == "present_position":
                    state.present = value
                elif name == "present_load":
                    state.load = value
                elif name == "present_voltage":
                    state.volts = value * model.voltage_unit
                else:
                    state.temperature = value

    def _arrived(self) -> None:
        """A full status read is in: believe the joints, finish the moves that arrived."""
        now = self._now if math.isfinite(self._now) else 0.0
        q = self._angles()
        if q is None:
            return
        # The packets are checked by their checksum or CRC already: a reading outside the
        # limits or too fast is counted against the link, the arm is where it says it is.
        # A limp arm (torque off) is moved by hand, as fast and as far as a hand likes.
        if not self.hold:
            return
        if self.guard.check(q, now) is not None and self.guard.verdict() is not None:
            self.lose_link(f"implausible joint readings: {self.guard.verdict()}")
            return
        done = []
        for move in self._moves:
            there = all(
                (present := self.servos[i].present) is not None
                and abs(present - c) <= ARRIVED_COUNTS
                for i, c in move.goal.items()
            )
            if there and now >= move.due - 1e-9:
                move.handle.update(MotionStatus.DONE)
            elif now > move.due + SETTLE_S:
                lag = {self._joint_of[i]: self.servos[i].present for i in move.goal}
                move.handle.update(
                    MotionStatus.FAILED,
                    error=Unreachable(
                        f"{self.model.name}: the servos stopped short of the goal: {lag}"
                    ),
                )
            else:
                total = float(np.linalg.norm(move.target - move.start))
                left = float(np.linalg.norm(move.target - q))
                move.handle.update(MotionStatus.RUNNING, progress=1 - left / total if total else 0)
                continue
            done.append(move)
        self._moves = [m for m in self._moves if m not in done]

    def _angles(self) -> np.ndarray | None:
        present = [self.servos[s.id].present for s in self.spec.joints]
        known = [p for p in present if p is not None]
        if len(known) < len(present):
            return None
        q = np.array(
            [float(s.calibration.degrees(p)) for s, p in zip(self.spec.joints, known, strict=True)]
        )
        # A joint sent to its limit reads up to a count past it (goals are whole counts):
        # it is at the limit, and a plan from there must not be refused for it.
        inside = np.clip(q, self.model.lower, self.model.upper)
        return np.where(np.abs(q - inside) < COUNT_DEG * 1.5, inside, q)

    def _status_error(self, packet: Packet) -> bool:
        """Act on a status packet's error byte; True when the arm was stopped."""
        servo = f"servo {packet.id} ({self._joint_of.get(packet.id, '?')})"
        if self.spec.bus == "feetech":
            names = feetech.error_names(packet.error)
        else:
            names = dynamixel.error_names(packet.error & 0x7F)
            if packet.error & dynamixel.ALERT:
                reg = self._model_of[packet.id].register("hardware_error")
                self._queue.appendleft(
                    _Request(
                        "a read of its hardware error",
                        [packet.id],
                        lambda w: self.codec.read(packet.id, reg.address, reg.size),
                        lambda p: self._stop_for(
                            servo,
                            dynamixel.error_names(dynamixel.ALERT, p.params[0] if p.params else 0),
                        ),
                        size=reg.size,
                    )
                )
                if not names:
                    return False
        return self._stop_for(servo, names)

    def _stop_for(self, servo: str, names: list[str]) -> bool:
        if not names:
            return False
        message = (
            f"{servo} reports {' and '.join(names)}: the arm is stopped and its torque off "
            "(let it cool, lighten the load or check the supply, then power-cycle the servo)"
        )
        if not self._ready:
            self._setup_error = message
            return True
        self.lose_link(message, reason=f"{servo}: {' and '.join(names)}")  # torque off first
        return True

    # ------------------------------------------------------------------ motion

    def _stream_step(self, now: float) -> tuple[dict[int, int], dict[int, float]]:
        """The set point due at ``now`` as goal counts and arrival times per servo."""
        active = self._stream
        if active is None:
            return {}, {}
        stream = active.stream
        if stream is None:
            stream = active.stream = TrajectoryStream(active.trajectory, now, self.stream_period)
            self.last_trajectory = (now, active.trajectory)
        if not stream.due(now):
            active.handle.update(MotionStatus.RUNNING, progress=stream.progress(now))
            return {}, {}
        point = stream.next(now)
        goals = self._counts(point.q)
        timing = {i: point.ramp_s for i in goals}
        if point.last:
            self._stream = None
            self._moves.append(
                _Move(active.handle, goals, now + point.ramp_s, active.start, point.q)
            )
        else:
            active.handle.update(MotionStatus.RUNNING, progress=stream.progress(now))
        return goals, timing

    def _counts(self, q: np.ndarray) -> dict[int, int]:
        return {
            s.id: int(round(float(s.calibration.counts(v))))
            for s, v in zip(self.spec.joints, q, strict=True)
        }

    def _grip_time(self, link: ServoLink, counts: int) -> float:
        previous = self._goals.get(link.id, counts)
        return abs(counts - previous) / (4096 / 360.0) / GRIP_SPEED_DEG_S

    def joints(self) -> np.ndarray:
        """Joint angles from the servos' present positions, degrees (home before the first)."""
        with self._lock:
            q = self._angles()
        return self.model.home.copy() if q is None else q

    @property
    def tool(self) -> ToolState:
        """The gripper's angle (degrees): as commanded, else as its servo reads it."""
        link = self.spec.gripper
        if link is None:
            return ToolState()
        if self._gripper_goal is not None:
            return ToolState(gripper=self._gripper_goal)
        present = self.servos[link.id].present
        return ToolState(
            gripper=None if present is None else float(link.calibration.degrees(present))
        )

    def move_joints(self, q: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Move every joint to ``q`` (degrees) along a timed trajectory (:meth:`follow_path`)."""
        return self.follow_path(np.atleast_2d(np.asarray(q, dtype=float)), speed)

    def follow_path(self, waypoints: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Follow joint ``waypoints`` ``(N, n)`` (degrees) from where the arm is, without
        stopping between them: timed within the joints' limits scaled by ``speed``,
        validated, then streamed. A refused path gives a FAILED handle; nothing is sent."""
        points = np.atleast_2d(np.asarray(waypoints, dtype=float))
        description = f"follow path to {np.round(points[-1], 2).tolist()}"
        try:
            checked = [self.checked_joints(w) for w in points]
        except Unreachable as exc:
            return self.refused(description, exc)
        fault = self.ensure_connected()
        if fault is not None:
            return self.refused(description, fault)
        key = ("path", tuple(self._counts(checked[-1]).items()), round(float(speed), 3))
        if self.is_duplicate(key) and self._last_handle is not None and not self._last_handle.done:
            return self._last_handle
        start = self.joints()
        try:
            trajectory = timed_path(
                np.vstack([start, *checked]), self.trajectory_kind, self.checker, speed
            )
        except PlanningError as exc:
            return self.refused(description, exc)
        handle = self.track(MotionHandle(description, checked[-1]))
        now = self.clock.now() if self.barrier is None else self._current_time()
        with self._lock:
            if self._stream is not None:
                self._stream.handle.update(MotionStatus.STOPPED)
            for move in self._moves:
                move.handle.update(MotionStatus.STOPPED)
            self._moves.clear()
            # the first set point goes with the next poll, which times the rest
            self._stream = _Stream(handle, trajectory, start)
        self.last_trajectory = (now, trajectory)
        handle.update(MotionStatus.RUNNING, progress=0.0)
        self.remember_sent(key)
        self._last_handle = handle
        return handle

    def time_path(self, path: np.ndarray, speed: float = 1.0) -> Trajectory:
        """The validated trajectory through ``path`` (raises PlanningError saying where it fails)."""
        return timed_path(path, self.trajectory_kind, self.checker, speed)

    def set_gripper(self, opening: float) -> MotionHandle:
        """Turn the gripper servo to ``opening`` degrees (DONE when it is there, or stalls
        on what it grips)."""
        link = self.spec.gripper
        if link is None:
            return super().set_gripper(opening)
        lo, hi = link.calibration.limits() if link.calibrated else (-180.0, 180.0)
        if not lo - 1e-9 <= opening <= hi + 1e-9:
            return self.refused(
                "gripper",
                Unreachable(
                    f"{self.model.name}: gripper {opening:g} deg is outside [{lo:.1f}, {hi:.1f}]"
                ),
            )
        fault = self.ensure_connected()
        if fault is not None:
            return self.refused("gripper", fault)
        handle = self.track(MotionHandle(f"gripper {opening:g}"))
        now = self.clock.now() if self.barrier is None else self._current_time()
        counts = int(round(float(link.calibration.counts(opening))))
        with self._lock:
            seconds = self._grip_time(link, counts)
            self._gripper_goal = float(opening)
            self._moves.append(_Move(handle, {}, now + seconds + 0.1, self.joints(), self.joints()))
        self.remember_sent(None)
        return handle

    def set_suction(self, on: bool) -> MotionHandle:
        """No pump here: grip (close the gripper) when ``on``, else open it."""
        if self.spec.gripper is None:
            handle = MotionHandle(f"suction {'on' if on else 'off'}")
            handle.update(
                MotionStatus.FAILED,
                error=HardwareFault("this arm has neither a pump nor a gripper", self.device),
            )
            return handle
        return self.set_gripper(self.spec.grip_closed if on else self.spec.grip_open)

    def stop(self) -> None:
        """Hold every joint where it is now (torque stays on)."""
        with self._lock:
            self._stream = None
            self._moves.clear()
            here = {s.id: self.servos[s.id].present for s in self.spec.joints}
            goals = {i: c for i, c in here.items() if c is not None}
            if goals and self._ready:
                self._goals.update(goals)
                self._queue.appendleft(self._goal_request(goals))
        self.stop_all()
        self.remember_sent(None)
        self._last_handle = None

    def write_registers(self, register: str, values: dict[int, int]) -> MotionHandle:
        """Write ``register`` of each servo (``{id: value}``), one answered write at a time;
        DONE once every servo confirmed (a Dynamixel's EEPROM only with its torque off)."""
        handle = self.track(MotionHandle(f"write {register}"))
        with self._lock:
            for n, (servo_id, value) in enumerate(values.items()):
                reg = self._model_of[servo_id].register(register)
                data = encode_value(value, reg.size, reg.encoding, self.codec.byteorder)
                last = n == len(values) - 1

                def write(
                    waiting: list[int], i: int = servo_id, d: bytes = data, a: int = reg.address
                ) -> bytes:
                    return self.codec.write(i, a, d)

                self._queue.append(
                    _Request(
                        f"the write of its {register}",
                        [servo_id],
                        write,
                        (lambda p: handle.update(MotionStatus.DONE)) if last else None,
                        size=0,
                    )
                )
        return handle

    def bus_facts(self) -> dict[str, object]:
        """How the bus went so far (JSON-safe, for the run log): ``bus``, ``lost_status``
        (status packets that did not come when asked), ``retries`` (asks a request gets
        past the first) and ``servos_heard`` (ids that answered)."""
        with self._lock:
            return {
                "bus": self.spec.bus,
                "lost_status": self.lost_status,
                "retries": self.retries,
                "servos_heard": sorted(self.servos_heard),
            }

    def joint_counts(self) -> list[int | None]:
        """Each arm joint's servo position as last read (counts, 4096 a turn), joint order."""
        with self._lock:
            return [self.servos[s.id].present for s in self.spec.joints]

    def present(self) -> dict[int, int | None]:
        """Every servo's present position as last read (counts), by id."""
        with self._lock:
            return {i: s.present for i, s in self.servos.items()}

    def _torque_off(self) -> bool:
        """Torque off on every servo in one sync write, past a fault too (best effort,
        bounded: :meth:`write_anyway`); True when it left."""
        return self.write_anyway(self._write_all("torque_enable", 0).packet([]))

    def on_fault(self) -> None:
        """Any fault (a servo's error, one gone silent, implausible readings, a driver
        error, a dead port): torque off on every servo, unless the bus never answered as
        these servos or this is a probe, which changes nothing."""
        if not self._probing and (self._torque_on or self.servos_heard):
            self._torque_off()

    def probe(self) -> None:
        """Connect as far as the pings and model numbers, changing nothing (detect-port)."""
        self._probing = True
        try:
            self.connect()
        finally:
            self._probing = False

    def close(self) -> None:
        """Torque off on every servo it turned on, then release the port (on every way out,
        a faulted link too: the torque-off is tried once more, bounded)."""
        if self._torque_on:
            self._torque_off()
        self._torque_on = False
        super().close()
