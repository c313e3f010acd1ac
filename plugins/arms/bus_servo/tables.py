"""The servo models armtree drives and the parts of their control tables it uses.

Addresses and sizes are the manufacturers' (Feetech's STS/SMS series table as
LeRobot's ``motors/feetech/tables.py`` lists it; ROBOTIS's X-series e-manual).
Registers are named alike across models, so the driver and the emulator ask
for ``present_position`` and each model says where it is and how it is coded:

* Feetech STS: two-byte positions, sign-magnitude with the sign in bit 15
  (bit 11 for the homing offset, bit 10 for the load); ``Present_Position =
  actual - Homing_Offset``; the speed of a move is ``Goal_Velocity`` in steps
  a second (0: as fast as it goes);
* Dynamixel X: four-byte positions in two's complement; ``Present_Position =
  actual + Homing_Offset``; with Drive Mode bit 2 (time-based profile) a move
  takes ``Profile_Velocity`` milliseconds (0: as fast as it goes).

Positions are 4096 counts a turn on all of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .bus import TWOS, UNSIGNED, Protocol
from .dynamixel import Dynamixel
from .feetech import Feetech

#: Encoder counts per turn of every model here.
COUNTS_PER_TURN = 4096
#: Dynamixel Drive Mode bit 2: a move's Profile_Velocity is its duration in ms.
TIME_BASED_PROFILE = 0x04


@dataclass(frozen=True)
class Register:
    """One control-table entry: ``address``, ``size`` bytes and its coding
    (:data:`~.bus.UNSIGNED`, :data:`~.bus.TWOS` or a sign-magnitude sign bit)."""

    address: int
    size: int
    encoding: int | None = UNSIGNED


_STS = {
    "firmware": Register(0, 1),
    "model_number": Register(3, 2),
    "id": Register(5, 1),
    "baud_rate": Register(6, 1),
    "return_delay": Register(7, 1),
    "status_return_level": Register(8, 1),
    "min_position_limit": Register(9, 2),
    "max_position_limit": Register(11, 2),
    "temperature_limit": Register(13, 1),
    "max_voltage": Register(14, 1),
    "min_voltage": Register(15, 1),
    "homing_offset": Register(31, 2, 11),
    "operating_mode": Register(33, 1),
    "torque_enable": Register(40, 1),
    "acceleration": Register(41, 1),
    "goal_position": Register(42, 2, 15),
    "goal_time": Register(44, 2),
    "goal_velocity": Register(46, 2, 15),
    "lock": Register(55, 1),
    "present_position": Register(56, 2, 15),
    "present_velocity": Register(58, 2, 15),
    "present_load": Register(60, 2, 10),
    "present_voltage": Register(62, 1),
    "present_temperature": Register(63, 1),
    "moving": Register(66, 1),
}

_X = {
    "model_number": Register(0, 2),
    "firmware": Register(6, 1),
    "id": Register(7, 1),
    "baud_rate": Register(8, 1),
    "return_delay": Register(9, 1),
    "drive_mode": Register(10, 1),
    "operating_mode": Register(11, 1),
    "homing_offset": Register(20, 4, TWOS),
    "temperature_limit": Register(31, 1),
    "max_voltage": Register(32, 2),
    "min_voltage": Register(34, 2),
    "max_position_limit": Register(48, 4),
    "min_position_limit": Register(52, 4),
    "torque_enable": Register(64, 1),
    "status_return_level": Register(68, 1),
    "hardware_error": Register(70, 1),
    "profile_acceleration": Register(108, 4),
    "goal_velocity": Register(112, 4),  # Profile_Velocity: the speed, or the time, of a move
    "goal_position": Register(116, 4, TWOS),
    "moving": Register(122, 1),
    "present_load": Register(126, 2, TWOS),  # Present_Load (XL430), Present_Current (XL330)
    "present_velocity": Register(128, 4, TWOS),
    "present_position": Register(132, 4, TWOS),
    "present_voltage": Register(144, 2),
    "present_temperature": Register(146, 1),
}

#: Feetech STS baud rates and their Baud_Rate codes.
_STS_BAUDS = {
    1_000_000: 0,
    500_000: 1,
    250_000: 2,
    128_000: 3,
    115_200: 4,
    57_600: 5,
    38_400: 6,
    19_200: 7,
}
#: Dynamixel X baud rates and their Baud Rate codes.
_X_BAUDS = {
    9_600: 0,
    57_600: 1,
    115_200: 2,
    1_000_000: 3,
    2_000_000: 4,
    3_000_000: 5,
    4_000_000: 6,
    4_500_000: 7,
}


@dataclass(frozen=True)
class ServoModel:
    """A servo model: its number (what a ping or address 3 / 0 reports), protocol,
    control table, baud rates and what it does unloaded.

    ``offset_sign`` is how the homing offset enters the present position
    (``present = actual + offset_sign * offset``); ``speed_counts_s`` its fastest
    turn (counts a second); ``volts`` its supply, ``voltage_unit`` volts per count
    of ``present_voltage``.
    """

    name: str
    number: int
    protocol: str
    registers: dict[str, Register]
    bauds: dict[int, int]
    offset_sign: int
    speed_counts_s: float
    volts: float
    voltage_unit: float = 0.1
    firmware: int = 1
    extra: dict[str, int] = field(default_factory=dict)

    def register(self, name: str) -> Register:
        """The register called ``name``; KeyError names the model when it has none."""
        try:
            return self.registers[name]
        except KeyError:
            raise KeyError(f"{self.name} has no register {name!r}") from None

    def span(self, first: str, last: str) -> tuple[int, int]:
        """Address and length of the bytes from register ``first`` to the end of ``last``."""
        a, b = self.register(first), self.register(last)
        return a.address, b.address + b.size - a.address


#: The models, by the name a profile gives (``model: sts3215``).
MODELS: dict[str, ServoModel] = {
    "sts3215": ServoModel(
        "sts3215", 777, "feetech", _STS, _STS_BAUDS, -1, 0.222**-1 * 60 / 360 * 4096, 7.4
    ),
    "xl430-w250": ServoModel(
        "xl430-w250", 1060, "dynamixel", _X, _X_BAUDS, 1, 57 / 60 * 4096, 12.0, firmware=46
    ),
    "xl330-m288": ServoModel(
        "xl330-m288", 1200, "dynamixel", _X, _X_BAUDS, 1, 103 / 60 * 4096, 5.0, firmware=46
    ),
}
#: Model numbers to names, for messages about the servo that answered.
BY_NUMBER = {m.number: m.name for m in MODELS.values()}

#: The protocols, by the name a profile gives (``bus: feetech``).
PROTOCOLS: dict[str, type[Protocol]] = {"feetech": Feetech, "dynamixel": Dynamixel}


def protocol_for(name: str) -> Protocol:
    """The :class:`~.bus.Protocol` called ``name``."""
    return PROTOCOLS[name]()


def model_name(number: int) -> str:
    """``sts3215 (777)``, or just the number of a model armtree does not know."""
    name = BY_NUMBER.get(number)
    return f"{name} ({number})" if name else f"model {number}"
