"""Feetech STS / SCS bus servo protocol (the SO-101's STS3215 servos).

As Feetech's SDK (``scservo_sdk``) and LeRobot's ``motors/feetech`` speak it:

* instruction packet ``FF FF ID LEN INST PARAM... CHK`` with ``LEN`` the number
  of parameters plus 2 and ``CHK = ~(ID + LEN + INST + sum(PARAMS)) & 0xFF``;
* status packet ``FF FF ID LEN ERR DATA... CHK``, the error byte's bits: 1
  input voltage, 2 angle sensor, 4 overheat, 8 over-current, 32 overload;
* a read or a sync request gives its address and length in one byte each; a
  sync read is answered by each listed servo with its own status packet, in
  the order the ids were listed; a sync write by nobody;
* values are little-endian on STS servos and big-endian on SCS ones.

``ping id 1`` is ``ff ff 01 02 01 fb``; writing goal position 2048 (address 42)
to id 1 is ``ff ff 01 05 03 2a 00 08 c4``.
"""

from __future__ import annotations

from armtree.plugins.arms.common.framing import CountedLengthParser

from .bus import Packet, Protocol

HEADER = b"\xff\xff"
#: Status error bits and what they mean.
ERROR_BITS = {
    0x01: "input voltage",
    0x02: "angle sensor",
    0x04: "overheat",
    0x08: "over-current",
    0x20: "overload",
}


def checksum(body: bytes) -> int:
    """Feetech's checksum of the bytes from the id to the last parameter."""
    return ~sum(body) & 0xFF


def valid(frame: bytes) -> bool:
    """True when ``frame`` (header to checksum) adds up and names an id below 0xFF."""
    return len(frame) >= 6 and frame[2] != 0xFF and checksum(frame[2:-1]) == frame[-1]


class Feetech(Protocol):
    """Feetech STS (little-endian, the default) or SCS (``big_endian=True``) servos."""

    name = "feetech"
    field_size = 1

    def __init__(self, big_endian: bool = False) -> None:
        self.byteorder = "big" if big_endian else "little"

    def frame(self, servo_id: int, code: int, params: bytes) -> bytes:
        """``FF FF ID LEN CODE PARAMS CHK``; at most 253 parameter bytes."""
        if len(params) > 253:
            raise ValueError(f"{len(params)} parameter bytes do not fit one packet (253)")
        body = bytes((servo_id, len(params) + 2, code)) + params
        return HEADER + body + bytes((checksum(body),))

    def status(self, servo_id: int, error: int, params: bytes = b"") -> bytes:
        """A status packet: the error byte where an instruction has its code."""
        return self.frame(servo_id, error & 0xFF, bytes(params))

    def frame_parser(self) -> CountedLengthParser:
        """Frames of ``LEN + 4`` bytes whose checksum adds up."""
        return CountedLengthParser(HEADER, 3, valid, min_length=2, max_length=255)

    def decode(self, frame: bytes, status: bool) -> Packet:
        """The packet in a checked frame; ``status`` says it is a servo's reply."""
        code, params = frame[4], bytes(frame[5:-1])
        if status:
            return Packet(frame[2], None, code, params)
        return Packet(frame[2], code, 0, params)


def error_names(error: int) -> list[str]:
    """What a status packet's error byte reports, in bit order."""
    return [name for bit, name in ERROR_BITS.items() if error & bit]
