"""Dynamixel Protocol 2.0 (the Koch arm's XL430 and XL330 servos).

As ROBOTIS's ``dynamixel_sdk`` (``protocol2_packet_handler.py``) speaks it:

* packet ``FF FF FD 00 ID LEN_L LEN_H INST PARAMS CRC_L CRC_H``, where ``LEN``
  counts the instruction, the parameters and the CRC;
* CRC-16 with polynomial 0x8005 and initial value 0, over everything from the
  header to the last parameter, sent low byte first;
* byte stuffing: wherever ``FF FF FD`` appears from the instruction on, an
  extra ``FD`` follows it (``LEN`` counts the stuffed bytes, the CRC covers them);
* a status packet has instruction 0x55 and then the error byte: bit 7 says a
  hardware error is latched (read Hardware Error Status, address 70), bits 0-6
  carry the result of the instruction (1 result fail, 2 instruction, 3 CRC,
  4 data range, 5 data length, 6 data limit, 7 access);
* a read or a sync request gives its address and length in two bytes each,
  little-endian; a ping's reply carries the model number and firmware version.
"""

from __future__ import annotations

from armtree.plugins.arms.common.framing import CountedLengthParser

from .bus import Packet, Protocol

HEADER = b"\xff\xff\xfd\x00"
#: Instruction of a status packet.
STATUS = 0x55
#: Status error bit: a hardware error is latched in the servo.
ALERT = 0x80
#: What bits 0-6 of a status packet's error byte say went wrong.
RESULT_ERRORS = {
    1: "result fail",
    2: "instruction error",
    3: "CRC error",
    4: "data range error",
    5: "data length error",
    6: "data limit error",
    7: "access error",
}
#: Hardware Error Status bits (address 70) and what they mean.
HARDWARE_ERRORS = {
    0x01: "input voltage",
    0x04: "overheat",
    0x08: "motor encoder",
    0x10: "electrical shock",
    0x20: "overload",
}


def _crc_table() -> tuple[int, ...]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else crc << 1
        table.append(crc & 0xFFFF)
    return tuple(table)


_TABLE = _crc_table()


def crc16(data: bytes, crc: int = 0) -> int:
    """CRC-16 (polynomial 0x8005, not reflected, initial 0) of ``data``, table-driven."""
    for byte in data:
        crc = ((crc << 8) ^ _TABLE[((crc >> 8) ^ byte) & 0xFF]) & 0xFFFF
    return crc


def stuff(payload: bytes) -> bytes:
    """``payload`` (instruction and parameters) with an ``FD`` added after each ``FF FF FD``.

    The header's own ``FF FF FD`` comes before the payload, so the first bytes
    may complete such a run only within the payload itself.
    """
    out = bytearray()
    for byte in payload:
        out.append(byte)
        if byte == 0xFD and out[-3:-1] == b"\xff\xff":
            out.append(0xFD)
    return bytes(out)


def unstuff(payload: bytes) -> bytes:
    """The inverse of :func:`stuff`: the ``FD`` after each ``FF FF FD`` removed."""
    out = bytearray()
    i = 0
    while i < len(payload):
        out.append(payload[i])
        if payload[i] == 0xFD and out[-3:-1] == b"\xff\xff" and payload[i + 1 : i + 2] == b"\xfd":
            i += 1
        i += 1
    return bytes(out)


def valid(frame: bytes) -> bool:
    """True when ``frame`` (header to CRC) has room for an instruction and its CRC matches."""
    return (
        len(frame) >= 10
        and frame[4] != 0xFF
        and crc16(frame[:-2]) == int.from_bytes(frame[-2:], "little")
    )


class Dynamixel(Protocol):
    """Dynamixel Protocol 2.0."""

    name = "dynamixel"
    byteorder = "little"
    field_size = 2

    def frame(self, servo_id: int, code: int, params: bytes) -> bytes:
        """Header, id, length, ``code`` and the parameters, stuffed, and the CRC."""
        payload = stuff(bytes((code,)) + params)
        head = HEADER + bytes((servo_id,)) + (len(payload) + 2).to_bytes(2, "little") + payload
        return head + crc16(head).to_bytes(2, "little")

    def status(self, servo_id: int, error: int, params: bytes = b"") -> bytes:
        """A status packet: instruction 0x55, the error byte, then the data."""
        return self.frame(servo_id, STATUS, bytes((error & 0xFF,)) + bytes(params))

    def ping_reply(self, model_number: int, firmware: int) -> bytes:
        """Model number (two bytes) and firmware version."""
        return model_number.to_bytes(2, "little") + bytes((firmware & 0xFF,))

    def frame_parser(self) -> CountedLengthParser:
        """Frames of ``LEN + 7`` bytes whose CRC matches."""
        return CountedLengthParser(HEADER, 5, valid, length_size=2, min_length=3, max_length=1024)

    def decode(self, frame: bytes, status: bool) -> Packet:
        """The packet in a checked frame, its stuffing removed; a status packet is recognised
        by its instruction, 0x55 (``status`` says which side expects what and is not needed)."""
        payload = unstuff(frame[7:-2])
        if payload[0] == STATUS and len(payload) >= 2:
            return Packet(frame[4], None, payload[1], bytes(payload[2:]))
        return Packet(frame[4], payload[0], 0, bytes(payload[1:]))


def error_names(error: int, hardware: int = 0) -> list[str]:
    """What a status packet's error byte and the servo's Hardware Error Status report."""
    names = [RESULT_ERRORS.get(error & 0x7F, f"error {error & 0x7F}")] if error & 0x7F else []
    if error & ALERT:
        names += [n for bit, n in HARDWARE_ERRORS.items() if hardware & bit] or ["hardware error"]
    return names
