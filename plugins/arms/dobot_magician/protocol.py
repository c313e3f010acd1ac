"""Dobot Magician serial protocol: 0xAA 0xAA framing, checksum, command ids and payloads.

Facts from the Dobot DLL (ProtocolDef.h, Packet.cpp) and pydobot 1.3.2:
``AA AA len id ctrl params... checksum`` with ``len = 2 + len(params)`` (< 0xAA),
``ctrl`` bit 0 = write, bit 1 = queued, checksum = ``(0 - (id + ctrl + sum(params))) mod 256``.
Payloads are packed little-endian C structs.
"""

from __future__ import annotations

import enum
import struct
from dataclasses import dataclass

SYNC = b"\xaa\xaa"
#: Longest payload a frame can announce (len must stay below 0xAA).
MAX_PARAMS = 0xA9 - 2
#: Longest run of bytes the parser keeps while waiting for the rest of a frame.
MAX_BUFFER = 2 + 1 + 0xA9 + 1

CTRL_WRITE = 0x01
CTRL_QUEUED = 0x02


class Cmd(enum.IntEnum):
    """Command ids used by armtree and pydobot 1.3.2 ([DLL ProtocolID.h])."""

    GET_POSE = 10
    SET_HOME = 31
    SUCTION_CUP = 62
    GRIPPER = 63
    PTP_JOINT_PARAMS = 80
    PTP_COORDINATE_PARAMS = 81
    PTP_JUMP_PARAMS = 82
    PTP_COMMON_PARAMS = 83
    PTP = 84
    CP = 91
    WAIT = 110
    IO_DO = 131
    QUEUE_START = 240
    QUEUE_STOP = 241
    QUEUE_FORCE_STOP = 242
    QUEUE_CLEAR = 245
    QUEUE_CURRENT_INDEX = 246
    QUEUE_LEFT_SPACE = 247


class PTPMode(enum.IntEnum):
    """PTP modes ([DLL DobotType.h enum PTPMode])."""

    JUMP_XYZ = 0
    MOVJ_XYZ = 1
    MOVL_XYZ = 2
    JUMP_ANGLE = 3
    MOVJ_ANGLE = 4
    MOVL_ANGLE = 5
    MOVJ_INC = 6
    MOVL_INC = 7
    MOVJ_XYZ_INC = 8
    JUMP_MOVL_XYZ = 9


@dataclass(frozen=True)
class Frame:
    """One decoded packet: command id, control byte and raw parameter bytes."""

    id: int
    ctrl: int
    params: bytes = b""

    @property
    def write(self) -> bool:
        """True for a set (write) request."""
        return bool(self.ctrl & CTRL_WRITE)

    @property
    def queued(self) -> bool:
        """True when the command goes into the arm's command queue."""
        return bool(self.ctrl & CTRL_QUEUED)


def checksum(body: bytes) -> int:
    """Checksum of ``id, ctrl, params``: the byte that makes their sum 0 mod 256."""
    return (-sum(body)) & 0xFF


def encode(frame_id: int, ctrl: int, params: bytes = b"") -> bytes:
    """The bytes of one packet, e.g. ``encode(10, 0) == bytes.fromhex('AAAA020A00F6')``."""
    if len(params) > MAX_PARAMS:
        raise ValueError(f"parameters of {len(params)} bytes do not fit a Magician frame")
    body = bytes([frame_id & 0xFF, ctrl & 0xFF]) + bytes(params)
    return SYNC + bytes([len(body)]) + body + bytes([checksum(body)])


class FrameParser:
    """Incremental decoder: feed any bytes, get whole frames; never raises, buffer bounded.

    Resynchronises like the DLL's PacketReadProcess(): on a bad sync byte, a
    length of 0xAA or more, or a wrong checksum it drops one byte and searches
    for the next ``AA AA``. ``dropped`` counts discarded bytes and ``bad_checksums``
    frames rejected for their checksum (the arm ignores them silently).
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        self.dropped = 0
        self.bad_checksums = 0

    def feed(self, data: bytes) -> list[Frame]:
        """Add ``data`` and return every complete, valid frame it finishes."""
        self._buf.extend(data)
        frames: list[Frame] = []
        buf = self._buf
        while True:
            start = buf.find(SYNC)
            if start < 0:
                # keep a trailing 0xAA: it may be the first half of a sync pair
                keep = 1 if buf[-1:] == b"\xaa" else 0
                self.dropped += len(buf) - keep
                del buf[: len(buf) - keep]
                break
            if start:
                self.dropped += start
                del buf[:start]
            if len(buf) < 3:
                break
            length = buf[2]
            if length < 2 or length >= 0xAA:
                self.dropped += 1
                del buf[:1]
                continue
            total = 3 + length + 1
            if len(buf) < total:
                break
            body = bytes(buf[3 : 3 + length])
            if (sum(body) + buf[3 + length]) & 0xFF:
                self.bad_checksums += 1
                self.dropped += 1
                del buf[:1]
                continue
            frames.append(Frame(body[0], body[1], body[2:]))
            del buf[:total]
        return frames

    @property
    def pending(self) -> int:
        """Bytes held while waiting for the rest of a frame (at most :data:`MAX_BUFFER`)."""
        return len(self._buf)


# --------------------------------------------------------------------------- payloads


def ptp_params(mode: int, x: float, y: float, z: float, r: float) -> bytes:
    """SetPTPCmd payload: u8 mode and four float32 (mm or degrees by mode)."""
    return struct.pack("<B4f", mode, x, y, z, r)


def unpack_ptp(params: bytes) -> tuple[int, tuple[float, float, float, float]]:
    """Mode and the four targets of a SetPTPCmd payload."""
    mode, *vals = struct.unpack_from("<B4f", params)
    return mode, tuple(vals)


def pose_params(x: float, y: float, z: float, r: float, joints: tuple[float, ...]) -> bytes:
    """GetPose reply payload: x, y, z, r and four joint angles, float32."""
    return struct.pack("<8f", x, y, z, r, *joints)


def unpack_pose(params: bytes) -> tuple[float, ...]:
    """x, y, z, r, j1, j2, j3, j4 from a GetPose reply."""
    return struct.unpack_from("<8f", params)


def index_params(index: int) -> bytes:
    """A queued-command index as the firmware returns it (uint64)."""
    return struct.pack("<Q", index)


def unpack_index(params: bytes) -> int:
    """The uint64 queue index of a reply."""
    return struct.unpack_from("<Q", params)[0]


def floats(params: bytes, count: int) -> tuple[float, ...]:
    """``count`` little-endian float32 values from the start of ``params``."""
    return struct.unpack_from(f"<{count}f", params)
