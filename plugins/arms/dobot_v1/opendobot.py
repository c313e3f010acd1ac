"""The open-dobot firmware's wire format (open-dobot firmware): requests, replies and CRC.

Request ``[id] [payload] [CRC hi] [CRC lo]``; reply ``[payload] [CRC hi] [CRC lo]``
whose CRC-16/CCITT (poly 0x1021, init 0xFFFF, MSB first) is not restarted: it
continues from the request's CRC. Step values and calibration rates go least
significant byte first, counters and accelerometers big-endian and signed.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

READY = 0
STEPS = 1
EXEC_QUEUE = 2
GET_ACCELS = 3
SWITCH_TO_ACCEL_REPORT_MODE = 4
CALIBRATE_JOINT = 5
EMERGENCY_STOP = 6
SET_COUNTERS = 7
GET_COUNTERS = 8
LASER_ON = 9
PUMP_ON = 10
VALVE_ON = 11
BOARD_VERSION = 12
CALIBRATOR_STATUS = 13

#: Request payload length (after the id) per command (open-dobot firmware, dobot.h and its handlers).
REQUEST_LEN = {
    0: 0,
    1: 17,
    2: 0,
    3: 0,
    4: 0,
    5: 10,
    6: 0,
    7: 12,
    8: 0,
    9: 1,
    10: 1,
    11: 1,
    12: 0,
    13: 0,
}
#: Reply payload length per command; None: no reply at all (EXEC_QUEUE).
REPLY_LEN: dict[int, int | None] = {
    0: 1, 1: 1, 2: None, 3: 12, 4: 12, 5: 0, 6: 0, 7: 0, 8: 12, 9: 1, 10: 1, 11: 1, 12: 1, 13: 1,
}  # fmt: skip

READY_MAGIC = 0x40
BOARD_FPGA = 0
BOARD_RAMPS = 1

#: Steps per revolution of every joint: 200 x 16 microsteps x 10:1 gearbox (open-dobot firmware).
STEPS_PER_REV = 32000
STEPS_PER_DEG = STEPS_PER_REV / 360.0
#: Accelerometer scale and zero of the FPGA board's sensors (open-dobot SDK).
ACCEL_SCALE = 493.56
ACCEL_ZERO = 1024
#: Slot length of the step queue, seconds (50 Hz).
SLOT = 0.02
QUEUE_SIZE = 100


@dataclass(frozen=True)
class Board:
    """A control board's step encoding (open-dobot firmware, fpga.cpp and ramps.cpp)."""

    name: str
    version: int
    step_coeff: int
    stop_bytes: bytes

    def steps_value(self, n: int) -> bytes:
        """The 4 bytes of a STEPS joint field for ``n`` steps in one slot."""
        if n <= 0:
            return self.stop_bytes
        return struct.pack("<I", max(1, self.step_coeff // n))

    def steps_of(self, raw: bytes) -> int:
        """Steps one slot makes for a 4-byte joint field (as the firmware reads it)."""
        value = struct.unpack("<I", raw)[0]
        if value == 0 or value > self.step_coeff:
            return 0
        return self.step_coeff // value

    def freq_value(self, hz: float) -> int:
        """freqToCmdVal: the calibration rate field for ``hz`` (reproduces the code)."""
        return int(self.step_coeff * 25 / hz)


FPGA = Board("fpga", BOARD_FPGA, 500000, bytes.fromhex("0242F000"))
RAMPS = Board("ramps", BOARD_RAMPS, 20000, bytes(4))
BOARDS = {"fpga": FPGA, "ramps": RAMPS}


def crc_ccitt(data: bytes, seed: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE of ``data`` continuing from ``seed``."""
    crc = seed
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def request(cmd: int, payload: bytes = b"") -> tuple[bytes, int]:
    """The request frame and its CRC (the seed of the reply's CRC)."""
    if len(payload) != REQUEST_LEN[cmd]:
        raise ValueError(
            f"command {cmd} takes {REQUEST_LEN[cmd]} payload bytes, not {len(payload)}"
        )
    body = bytes([cmd]) + payload
    crc = crc_ccitt(body)
    return body + crc.to_bytes(2, "big"), crc


def reply(payload: bytes, request_crc: int) -> bytes:
    """The reply frame to a request whose CRC was ``request_crc``."""
    return payload + crc_ccitt(payload, request_crc).to_bytes(2, "big")


def check_reply(frame: bytes, request_crc: int) -> bytes | None:
    """The payload of a reply frame if its CRC continues ``request_crc``, else None."""
    if len(frame) < 2:
        return None
    payload = frame[:-2]
    if crc_ccitt(payload, request_crc).to_bytes(2, "big") != frame[-2:]:
        return None
    return payload


def steps_payload(
    board: Board, steps: tuple[int, int, int], dirs: tuple[int, int, int], grab: int, rot: int
) -> bytes:
    """STEPS payload: three step fields, the direction byte, gripper and rotation PWM."""
    control = (dirs[0] & 1) | ((dirs[1] & 1) << 1) | ((dirs[2] & 1) << 2)
    return (
        b"".join(board.steps_value(n) for n in steps)
        + bytes([control])
        + struct.pack("<HH", grab, rot)
    )


def calibrate_payload(
    forward: int, back: int, pin: int, joint: int, toward: int, pullup: bool, normal_high: bool
) -> bytes:
    """CALIBRATE_JOINT payload (open-dobot firmware, its control bits)."""
    control = (joint & 3) | ((toward & 1) << 2) | (int(pullup) << 3) | (int(normal_high) << 4)
    return struct.pack("<II", forward, back) + bytes([pin, control])


def counters_payload(base: int, rear: int, fore: int) -> bytes:
    """SET_COUNTERS payload / GET_COUNTERS reply: three big-endian int32."""
    return struct.pack(">iii", base, rear, fore)


def parse_counters(payload: bytes) -> tuple[int, int, int]:
    """Three big-endian int32."""
    return struct.unpack(">iii", payload)


def parse_accels(payload: bytes) -> tuple[int, ...]:
    """rearX, rearY, rearZ, frontX, frontY, frontZ as big-endian int16."""
    return struct.unpack(">6h", payload)


def accel_to_radians(raw: int, offset: int = ACCEL_ZERO) -> float:
    """accelToRadians of the FPGA board: asin((raw - offset) / 493.56)."""
    return math.asin(max(-1.0, min(1.0, (raw - offset) / ACCEL_SCALE)))
