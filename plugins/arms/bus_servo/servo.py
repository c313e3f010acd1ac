"""One simulated bus servo: its control table, its motion and its protections.

A :class:`SimServo` keeps the bytes of its control table as the firmware does
(its id, baud rate, offsets, goals, torque switch) and works out the present
registers from where its horn is when they are read. Its encoder reads the
horn's ``actual`` position, 0-4095 counts a turn; the present position adds the
homing offset the way the model does (:class:`~.tables.ServoModel`).

With torque on, a goal position makes the horn move to it at a constant speed:
the one its speed register asks (Feetech ``Goal_Velocity``, counts a second;
Dynamixel with a time-based profile, ``Profile_Velocity`` ms for the whole
move), never faster than the servo turns unloaded; 0 means as fast as it
turns. With torque off it holds nothing: a hand may turn it
(:meth:`SimServo.turn_by_hand`). A latched protection (overload, overheat)
switches torque off, as the real servo does, and shows in every status packet
until torque is switched on again; an overload stays latched while the load
lasts. Times are seconds on the run's clock.
"""

from __future__ import annotations

from dataclasses import dataclass

from .bus import decode_value, encode_value
from .dynamixel import ALERT
from .tables import COUNTS_PER_TURN, TIME_BASED_PROFILE, ServoModel

#: Feetech status bits and Dynamixel Hardware Error Status bits of each protection.
PROTECTIONS = {
    "feetech": {"voltage": 0x01, "overheat": 0x04, "overload": 0x20},
    "dynamixel": {"voltage": 0x01, "overheat": 0x04, "overload": 0x20},
}
#: Dynamixel status error: the address may not be written now.
ACCESS_ERROR = 7
#: Temperature (deg C) a servo reports, and the one past which it protects itself.
TEMPERATURE_C = 31
OVERHEAT_C = 72
#: Dynamixel Profile_Velocity unit when the profile is velocity-based: 0.229 rev/min.
DXL_VELOCITY_UNIT = 0.229 * COUNTS_PER_TURN / 60.0


@dataclass
class _Ramp:
    """The horn's motion: from ``p0`` at ``t0`` to ``p1`` at ``t1`` (counts), linearly."""

    p0: float
    p1: float
    t0: float
    t1: float

    def at(self, t: float) -> float:
        if t >= self.t1 or self.t1 <= self.t0:
            return self.p1
        if t <= self.t0:
            return self.p0
        return self.p0 + (self.p1 - self.p0) * (t - self.t0) / (self.t1 - self.t0)


class SimServo:
    """A servo of ``model`` with id ``servo_id``, its horn at ``actual`` counts at power-up.

    ``homing_offset`` and ``baud`` are what its EEPROM holds. Values are little-endian,
    as on every model in :data:`~.tables.MODELS`.
    """

    def __init__(
        self,
        model: ServoModel,
        servo_id: int,
        actual: float,
        *,
        homing_offset: int = 0,
        baud: int = 1_000_000,
        return_delay: int = 0,
    ) -> None:
        self.model = model
        self.mem = bytearray(256)
        self._ramp = _Ramp(float(actual), float(actual), 0.0, 0.0)
        #: Latched protections (``"overload"``, ``"overheat"``, ``"voltage"``).
        self.latched: set[str] = set()
        #: Protections that trip again whenever torque comes on (a load that stays).
        self.held: set[str] = set()
        self._put("model_number", model.number)
        self._put("firmware", model.firmware)
        self._put("id", servo_id)
        self._put("baud_rate", model.bauds[baud])
        self._put("return_delay", return_delay)
        self._put("status_return_level", 1 if model.protocol == "feetech" else 2)
        self._put("homing_offset", homing_offset)
        self._put("max_position_limit", COUNTS_PER_TURN - 1)
        self._put("temperature_limit", 70)
        self._put("goal_position", round(self.present(0.0)))
        if model.protocol == "feetech":
            self._put("operating_mode", 0)
        else:
            self._put("operating_mode", 3)  # position control

    # ------------------------------------------------------------------ registers

    def _put(self, name: str, value: int) -> None:
        reg = self.model.register(name)
        self.mem[reg.address : reg.address + reg.size] = encode_value(value, reg.size, reg.encoding)

    def get(self, name: str) -> int:
        """The value of register ``name`` as last stored (present ones: at the last read)."""
        reg = self.model.register(name)
        return decode_value(bytes(self.mem[reg.address : reg.address + reg.size]), reg.encoding)

    @property
    def id(self) -> int:
        """The servo's id (its ID register)."""
        return self.get("id")

    @property
    def baud(self) -> int:
        """The baud rate its Baud_Rate register selects."""
        code = self.get("baud_rate")
        return next((b for b, c in self.model.bauds.items() if c == code), 0)

    @property
    def torque(self) -> bool:
        """True while torque is on."""
        return bool(self.mem[self.model.register("torque_enable").address])

    # ------------------------------------------------------------------ positions

    def actual(self, t: float) -> float:
        """Where the horn is at ``t``, encoder counts (not wrapped)."""
        return self._ramp.at(t)

    def present(self, t: float) -> float:
        """The present position at ``t`` as the servo reports it (counts, not rounded)."""
        return self.actual(t) + self.model.offset_sign * self.get("homing_offset")

    def _to_actual(self, present: float) -> float:
        return present - self.model.offset_sign * self.get("homing_offset")

    def moving(self, t: float) -> bool:
        """True while the horn is on its way to the goal."""
        return t < self._ramp.t1 and self._ramp.p1 != self._ramp.p0

    def hold(self, t: float) -> None:
        """Stop where the horn is at ``t``."""
        p = self.actual(t)
        self._ramp = _Ramp(p, p, t, t)

    def turn_by_hand(self, actual: float, t: float) -> bool:
        """Put the horn at ``actual`` counts at ``t`` when torque is off; False when it holds."""
        if self.torque:
            return False
        self._ramp = _Ramp(float(actual), float(actual), t, t)
        return True

    def slip(self, counts: float, t: float) -> None:
        """The horn turned by ``counts`` against the servo (a knock). With torque on the
        servo's position loop takes it back to its goal, as a real one does (its encoder
        is absolute: nothing is lost); limp, it stays where it was knocked."""
        p = self.actual(t) + counts
        self._ramp = _Ramp(p, p, t, t)
        if self.torque:
            self._goal(t)

    def _duration(self, distance: float) -> float:
        fastest = distance / self.model.speed_counts_s
        speed = self.get("goal_velocity")
        if self.model.protocol == "dynamixel":
            if self.get("drive_mode") & TIME_BASED_PROFILE:
                return max(fastest, speed / 1000.0)
            return fastest if speed <= 0 else max(fastest, distance / (speed * DXL_VELOCITY_UNIT))
        return fastest if speed == 0 else max(fastest, distance / abs(speed))

    def _goal(self, t: float) -> None:
        start = self.actual(t)
        target = self._to_actual(self.get("goal_position"))
        self._ramp = _Ramp(start, target, t, t + self._duration(abs(target - start)))

    # ------------------------------------------------------------------ protections

    def trip(self, protection: str, t: float, *, lasting: bool = True) -> None:
        """Latch ``protection`` at ``t``: torque off, the horn where it is; with ``lasting``
        it trips again whenever torque comes on (the load is still there)."""
        self.latched.add(protection)
        if lasting:
            self.held.add(protection)
        self.hold(t)
        self.mem[self.model.register("torque_enable").address] = 0

    def error_byte(self) -> int:
        """The error byte of its status packets."""
        bits = PROTECTIONS[self.model.protocol]
        if self.model.protocol == "feetech":
            return sum(bits[p] for p in self.latched)
        return ALERT if self.latched else 0

    # ------------------------------------------------------------------ access

    def read(self, address: int, length: int, t: float) -> bytes:
        """``length`` bytes of the table from ``address`` at ``t``, present values refreshed."""
        self._refresh(t)
        return bytes(self.mem[address : address + length])

    def write(self, address: int, data: bytes, t: float) -> int:
        """Store ``data`` at ``address`` at ``t`` and act on it (torque on: the horn goes to
        the goal register, as it is; off: it holds nothing). Returns the status error:
        a Dynamixel refuses writes below the torque switch (its EEPROM) while torque is on
        (access error, 7), and stores nothing."""
        end = address + len(data)
        torque_at = self.model.register("torque_enable").address
        goal = self.model.register("goal_position")
        if self.model.protocol == "dynamixel" and self.torque and address < torque_at:
            return ACCESS_ERROR
        self.mem[address:end] = data
        if address <= torque_at < end:
            if self.mem[torque_at]:
                self.latched.clear()
                if self.held:
                    self.trip(sorted(self.held)[0], t)
                    return 0
                self._goal(t)
            else:
                self.hold(t)
        if self.torque and address < goal.address + goal.size and goal.address < end:
            self._goal(t)
        return 0

    def _refresh(self, t: float) -> None:
        present = self.present(t)
        speed = 0.0
        ramp = self._ramp
        if self.moving(t) and ramp.t1 > ramp.t0:
            speed = (ramp.p1 - ramp.p0) / (ramp.t1 - ramp.t0)
        self._put("present_position", _clamp(round(present), self.model, "present_position"))
        self._put("present_velocity", _clamp(round(speed), self.model, "present_velocity"))
        load = 0 if not self.torque else (1000 if "overload" in self.latched else 40)
        self._put("present_load", load if speed >= 0 else -load)
        self._put("present_voltage", round(self.model.volts / self.model.voltage_unit))
        hot = "overheat" in self.latched
        self._put("present_temperature", OVERHEAT_C if hot else TEMPERATURE_C)
        self._put("moving", int(self.moving(t)))
        if self.model.protocol == "dynamixel":
            bits = PROTECTIONS["dynamixel"]
            self._put("hardware_error", sum(bits[p] for p in self.latched))


def _clamp(value: int, model: ServoModel, name: str) -> int:
    """``value`` within what register ``name`` can hold."""
    reg = model.register(name)
    if reg.encoding is None:
        return min(max(value, 0), (1 << (8 * reg.size)) - 1)
    bits = 8 * reg.size - 1 if reg.encoding < 0 else reg.encoding
    limit = (1 << bits) - 1
    return min(max(value, -limit), limit)
