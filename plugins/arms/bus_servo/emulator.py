"""A bus of serial servos behind a pseudo-terminal, byte for byte (Feetech STS or Dynamixel 2.0).

Every servo on the bus is a :class:`~.servo.SimServo` with its own control
table. The emulator reads instruction packets as the servos would (a packet
that fails its checksum or CRC is ignored, as on the wire), lets each servo
addressed act on it, and sends the status packets they answer with, in the
order the protocol prescribes: a sync read is answered by each listed servo in
turn, a broadcast write and a sync write by nobody. A Dynamixel answers an
instruction it does not know with an instruction error; a Feetech ignores it.

Each arm joint (and the gripper) is one servo mounted on it: the joint angle
is ``direction * (actual - zero) * 360 / 4096`` degrees of the horn's encoder
counts (:class:`Mount`), so the world sees the arm where the servos really are.

Faults on request (:meth:`BusServoEmulator.inject`), besides the byte faults
every emulator has (``corrupt``, ``drop``, ``cut``): ``lost_replies`` (``rate``
per status packet and/or the next ``count``), ``latency`` (``seconds`` before
each reply), ``overload`` and ``overheat`` (on ``joint`` index, or servo ``id``,
``after_s`` seconds from now: the servo latches the protection and drops its
torque, and the load stays), ``missed_steps`` (a horn knocked by ``amount``
degrees). Times are seconds on the run's clock.
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from armtree.api.clock import Clock
from armtree.api.rig import ToolState
from armtree.maths.motion.kinematics import KinematicModel
from armtree.plugins.arms.common.pty_emulator import FAULTS, PtyEmulator

from . import bus
from .bus import BROADCAST, Packet, PacketReader, Protocol
from .servo import SimServo
from .tables import COUNTS_PER_TURN

#: Faults this emulator takes besides the byte faults every emulator has.
BUS_FAULTS = ("lost_replies", "latency", "overload", "overheat")
#: Counts of the encoder per degree of the horn.
COUNTS_PER_DEG = COUNTS_PER_TURN / 360.0
#: Dynamixel's status error for an instruction it does not know.
INSTRUCTION_ERROR = 2


@dataclass(frozen=True)
class Mount:
    """How a servo turns a joint: the joint is at ``direction * (actual - zero)`` counts,
    converted to degrees, when the servo's horn is at ``actual``."""

    servo_id: int
    zero: float
    direction: int = 1

    def degrees(self, actual: float) -> float:
        """The joint angle (deg) for the horn at ``actual`` counts."""
        return self.direction * (actual - self.zero) / COUNTS_PER_DEG

    def counts(self, degrees: float) -> float:
        """The horn's position (counts) that puts the joint at ``degrees``."""
        return self.zero + self.direction * degrees * COUNTS_PER_DEG


class BusServoEmulator(PtyEmulator):
    """The servos of an arm on one bus: ``servos`` answer ``protocol`` on the pty.

    ``mounts`` are the arm joints' servos in the model's joint order; ``gripper``
    the gripper's, whose angle (degrees) the tool reports. ``latency_s`` delays
    every reply.
    """

    def __init__(
        self,
        model: KinematicModel,
        clock: Clock,
        protocol: Protocol,
        servos: Sequence[SimServo],
        mounts: Sequence[Mount],
        *,
        gripper: Mount | None = None,
        latency_s: float = 0.0,
        seed: int = 0,
    ) -> None:
        super().__init__(model, clock, seed=seed)
        self.protocol = protocol
        self.servos = {s.id: s for s in servos}
        if len(self.servos) != len(servos):
            raise ValueError("two servos on one bus share an id")
        self.mounts = tuple(mounts)
        self.gripper_mount = gripper
        for mount in (*self.mounts, *([gripper] if gripper else [])):
            if mount.servo_id not in self.servos:
                raise ValueError(f"no servo {mount.servo_id} on the bus for a joint")
        self.latency_s = float(latency_s)
        #: Status packets the ``lost_replies`` fault swallowed.
        self.lost_replies = 0
        self._lose_rate = 0.0
        self._lose_count = 0
        self._reader = PacketReader(protocol, status=False)
        self._replies: list[tuple[float, int, bytes]] = []
        self._trips: list[tuple[float, int, str, int]] = []
        self._order = itertools.count()
        self._pending: dict[int, tuple[int, bytes]] = {}

    # ------------------------------------------------------------------ the arm

    def servo_of(self, joint: int) -> SimServo:
        """The servo that turns arm joint ``joint`` (an index into the model's joints)."""
        return self.servos[self.mounts[joint].servo_id]

    def _angles(self, t: float) -> np.ndarray:
        return np.array([m.degrees(self.servos[m.servo_id].actual(t)) for m in self.mounts])

    def true_joints(self) -> np.ndarray:
        """Joint angles where the servos' horns are, degrees."""
        with self._lock:
            return self._angles(self.time)

    def reported_joints(self) -> np.ndarray:
        """The same: each servo's encoder reads its own horn."""
        return self.true_joints()

    def tool(self) -> ToolState:
        """The gripper's angle (degrees), when the arm has one; no suction."""
        if self.gripper_mount is None:
            return ToolState()
        with self._lock:
            servo = self.servos[self.gripper_mount.servo_id]
            return ToolState(gripper=float(self.gripper_mount.degrees(servo.actual(self.time))))

    def turn_by_hand(self, joints: Sequence[float], gripper: float | None = None) -> list[int]:
        """A hand moves the joints (and the gripper) to these angles (deg); only servos
        without torque give way. The ids of those that held are returned."""
        with self._lock:
            held = []
            pairs = list(zip(self.mounts, joints, strict=True))
            if gripper is not None and self.gripper_mount is not None:
                pairs.append((self.gripper_mount, gripper))
            for mount, angle in pairs:
                if not self.servos[mount.servo_id].turn_by_hand(mount.counts(angle), self.time):
                    held.append(mount.servo_id)
            return held

    def halt(self, reason: str) -> None:
        """Every servo stops where it is."""
        with self._lock:
            for servo in self.servos.values():
                servo.hold(self.time)
            self.halted_reason = reason

    # ------------------------------------------------------------------ faults

    def inject(self, fault: str, **options: float) -> None:
        """Inject a fault (see the module docstring); byte faults go to the base emulator."""
        with self._lock:
            if fault == "lost_replies":
                self._lose_rate = float(options.get("rate", 0.0))
                self._lose_count += int(options.get("count", 0))
            elif fault == "latency":
                self.latency_s = float(options.get("seconds", 0.0))
            elif fault in ("overload", "overheat"):
                servo_id = self._target(options)
                at = self.time + float(options.get("after_s", 0.0))
                heapq.heappush(self._trips, (at, next(self._order), fault, servo_id))
            elif fault == "missed_steps":
                joint = int(options.get("joint", 0))
                counts = self.mounts[joint].direction * float(options["amount"]) * COUNTS_PER_DEG
                self.servo_of(joint).slip(counts, self.time)
            elif fault in FAULTS:
                super().inject(fault, **options)
            else:
                known = ", ".join((*FAULTS, *BUS_FAULTS))
                raise ValueError(f"{type(self).__name__}: unknown fault {fault!r} (known: {known})")

    def _target(self, options: dict[str, float]) -> int:
        if "id" in options:
            servo_id = int(options["id"])
            if servo_id not in self.servos:
                raise ValueError(f"no servo {servo_id} on the bus")
            return servo_id
        return self.mounts[int(options.get("joint", 0))].servo_id

    # ------------------------------------------------------------------ PtyEmulator hooks

    def on_bytes(self, data: bytes, t: float) -> None:
        """Act on every complete instruction packet; queue the status packets it earns."""
        for packet in self._reader.feed(data):
            for reply in self._answer(packet, t):
                self._reply(reply, t)
        self._send_due(t)

    def next_event_time(self) -> float | None:
        """The next reply due, or the next protection to trip."""
        times = [r[0] for r in self._replies[:1]] + [x[0] for x in self._trips[:1]]
        later = [x for x in times if x > self.time]
        return min(later) if later else None

    def on_timer(self, t: float) -> None:
        """Trip the protections due and send the replies due at ``t``."""
        while self._trips and self._trips[0][0] <= t:
            _, _, protection, servo_id = heapq.heappop(self._trips)
            self.servos[servo_id].trip(protection, t)
        self._send_due(t)

    # ------------------------------------------------------------------ the bus

    def _reply(self, data: bytes, t: float) -> None:
        if self._lose_count > 0:
            self._lose_count -= 1
            self.lost_replies += 1
            return
        if self._lose_rate and self._rng.random() < self._lose_rate:
            self.lost_replies += 1
            return
        heapq.heappush(self._replies, (t + self.latency_s, next(self._order), data))

    def _send_due(self, t: float) -> None:
        out = bytearray()
        while self._replies and self._replies[0][0] <= t:
            out += heapq.heappop(self._replies)[2]
        if out:
            self.send(bytes(out))

    def _answer(self, packet: Packet, t: float) -> list[bytes]:
        """The status packets ``packet`` earns, in the order the servos send them."""
        code = packet.instruction
        proto = self.protocol
        try:
            if code == bus.SYNC_READ:
                address, length, ids = proto.sync_read_ids(packet.params)
                return [self._status(s, s.read(address, length, t)) for s in self._on_bus(ids)]
            if code == bus.SYNC_WRITE:
                address, items = proto.sync_write_items(packet.params)
                for servo in self._on_bus(items):
                    servo.write(address, items[servo.id], t)
                return []
            targets = self._addressed(packet.id)
            if code == bus.ACTION:
                for servo in targets:
                    address, data = self._pending.pop(servo.id, (0, b""))
                    if data:
                        servo.write(address, data, t)
                return []
            return [r for s in targets if (r := self._one(s, packet, t)) is not None]
        except ValueError:
            return []  # parameters that do not make a request: the firmware ignores them

    def _one(self, servo: SimServo, packet: Packet, t: float) -> bytes | None:
        """What one addressed servo answers (None: nothing)."""
        code = packet.instruction
        proto = self.protocol
        broadcast = packet.id == BROADCAST
        level = servo.get("status_return_level")
        if code == bus.PING:
            return self._status(servo, proto.ping_reply(servo.model.number, servo.model.firmware))
        if code == bus.READ:
            address, length = proto.address_length(packet.params)
            if broadcast or (proto.name == "dynamixel" and level < 1):
                return None
            return self._status(servo, servo.read(address, length, t))
        if code in (bus.WRITE, bus.REG_WRITE):
            n = proto.field_size
            address = int.from_bytes(packet.params[:n], "little")
            data = packet.params[n:]
            error = 0
            if code == bus.WRITE:
                error = servo.write(address, data, t)
            else:
                self._pending[servo.id] = (address, data)
            silent = broadcast or level < (2 if proto.name == "dynamixel" else 1)
            return None if silent else self._status(servo, b"", error)
        if proto.name == "dynamixel" and not broadcast:
            return proto.status(servo.id, INSTRUCTION_ERROR)
        return None

    def _status(self, servo: SimServo, data: bytes, error: int = 0) -> bytes:
        return self.protocol.status(servo.id, servo.error_byte() | error, data)

    def _addressed(self, servo_id: int) -> list[SimServo]:
        if servo_id == BROADCAST:
            return [self.servos[i] for i in sorted(self.servos)]
        servo = self.servos.get(servo_id)
        return [] if servo is None else [servo]

    def _on_bus(self, ids: object) -> list[SimServo]:
        return [self.servos[i] for i in ids if i in self.servos]  # type: ignore[attr-defined]
