"""What the two servo bus protocols share: packets, the requests a host makes, values.

Feetech STS/SCS (:mod:`.feetech`) and Dynamixel Protocol 2.0 (:mod:`.dynamixel`)
carry the same conversation in different frames: a host sends an instruction
packet (ping, read, write, sync read, sync write) to one servo id or to the
broadcast id 0xFE, and every servo addressed by a request that wants an answer
replies with a status packet holding its error byte and the data asked for. A
:class:`Protocol` turns requests into bytes and bytes back into
:class:`Packet` s, for the driver (:mod:`.driver`) and the emulator
(:mod:`.emulator`) alike, so both speak the protocol from one definition.

Register values travel as little-endian (STS, Dynamixel) or big-endian (SCS)
integers; a signed register is two's complement (Dynamixel) or sign-magnitude
with its sign in a given bit (Feetech). :func:`encode_value` and
:func:`decode_value` do both.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Final

from armtree.plugins.arms.common.framing import CountedLengthParser

#: The id every servo listens to (no servo answers a broadcast write).
BROADCAST = 0xFE
#: The highest id a servo may have.
MAX_ID = 0xFC

#: Instruction codes both protocols use for the same request.
PING, READ, WRITE, REG_WRITE, ACTION = 0x01, 0x02, 0x03, 0x04, 0x05
SYNC_READ, SYNC_WRITE = 0x82, 0x83
INSTRUCTIONS = {
    PING: "ping",
    READ: "read",
    WRITE: "write",
    REG_WRITE: "reg_write",
    ACTION: "action",
    SYNC_READ: "sync_read",
    SYNC_WRITE: "sync_write",
}

#: Register encodings: an unsigned value, or two's complement (``TWOS``); any other
#: number is the bit that carries the sign of a sign-magnitude value. Final, so that
#: after ``encoding is UNSIGNED`` mypy knows the encoding is a number.
UNSIGNED: Final = None
TWOS = -1


@dataclass(frozen=True)
class Packet:
    """One decoded packet.

    ``instruction`` is the request's code for an instruction packet and None for a
    status packet, whose ``error`` byte is then set; ``params`` are the bytes after
    the code or error byte (Dynamixel's byte stuffing removed).
    """

    id: int
    instruction: int | None
    error: int
    params: bytes

    @property
    def is_status(self) -> bool:
        """True for a servo's reply."""
        return self.instruction is None


def encode_value(value: int, size: int, encoding: int | None, byteorder: str = "little") -> bytes:
    """``value`` as a register of ``size`` bytes: unsigned, two's complement or sign-magnitude.

    Raises ValueError when the value does not fit (a sign-magnitude value's
    magnitude must fit below its sign bit).
    """
    value = int(value)
    if encoding is UNSIGNED:
        if not 0 <= value < 1 << (8 * size):
            raise ValueError(f"{value} does not fit an unsigned {size}-byte register")
        raw = value
    elif encoding == TWOS:
        half = 1 << (8 * size - 1)
        if not -half <= value < half:
            raise ValueError(f"{value} does not fit a signed {size}-byte register")
        raw = value & ((1 << (8 * size)) - 1)
    else:
        if not 0 < encoding < 8 * size:
            raise ValueError(f"sign bit {encoding} is outside a {size}-byte register")
        if abs(value) >= 1 << encoding:
            raise ValueError(f"{value} does not fit a sign-magnitude register (bit {encoding})")
        raw = abs(value) | ((1 << encoding) if value < 0 else 0)
    return raw.to_bytes(size, byteorder)  # type: ignore[arg-type]


def decode_value(data: bytes, encoding: int | None, byteorder: str = "little") -> int:
    """The register value in ``data`` (its whole length), as :func:`encode_value` wrote it."""
    raw = int.from_bytes(data, byteorder)  # type: ignore[arg-type]
    if encoding is UNSIGNED:
        return raw
    if encoding == TWOS:
        half = 1 << (8 * len(data) - 1)
        return raw - 2 * half if raw >= half else raw
    magnitude = raw & ((1 << encoding) - 1)
    return -magnitude if raw >> encoding & 1 else magnitude


class PacketReader:
    """Packets from a byte stream: resynchronises on noise, drops frames that fail their check.

    ``status`` says which side this is: True on the host (it reads the servos'
    status packets), False on the bus (it reads instruction packets).
    ``discarded`` counts the bytes skipped.
    """

    def __init__(self, protocol: Protocol, status: bool) -> None:
        self.protocol = protocol
        self.status = status
        self._frames = protocol.frame_parser()

    @property
    def discarded(self) -> int:
        """Bytes skipped so far: noise, cut packets and packets that failed their check."""
        return self._frames.discarded

    @property
    def buffered(self) -> int:
        """Bytes of a packet not yet complete."""
        return self._frames.buffered

    def feed(self, data: bytes) -> list[Packet]:
        """Add bytes; every complete packet, in order."""
        return [self.protocol.decode(f, self.status) for f in self._frames.feed(data)]

    def reset(self) -> None:
        """Forget a partial packet."""
        self._frames.reset()


class Protocol(ABC):
    """One servo bus protocol: frames, requests and replies.

    Subclasses define the frame (:meth:`frame`, :meth:`frame_parser`,
    :meth:`decode`) and how a request's parameters are laid out; the request
    builders below are the same for both.
    """

    #: Short name used in profiles (``bus: feetech``).
    name: str = ""
    #: Byte order of register values.
    byteorder: str = "little"
    #: Bytes of a sync request's address and length fields.
    field_size: int = 1

    # ------------------------------------------------------------------ frames

    @abstractmethod
    def frame(self, servo_id: int, code: int, params: bytes) -> bytes:
        """One packet: ``code`` is the instruction, or for a status packet its marker and error."""

    @abstractmethod
    def frame_parser(self) -> CountedLengthParser:
        """A resynchronising parser of this protocol's frames."""

    @abstractmethod
    def decode(self, frame: bytes, status: bool) -> Packet:
        """The packet in a frame the parser accepted."""

    @abstractmethod
    def status(self, servo_id: int, error: int, params: bytes = b"") -> bytes:
        """A servo's status packet."""

    def ping_reply(self, model_number: int, firmware: int) -> bytes:
        """A ping's status parameters (none for Feetech; Dynamixel adds model and firmware)."""
        return b""

    def instruction(self, servo_id: int, code: int, params: bytes = b"") -> bytes:
        """An instruction packet to ``servo_id`` (0 to 252, or 254 to broadcast)."""
        if not (0 <= servo_id <= MAX_ID or servo_id == BROADCAST):
            raise ValueError(f"servo id {servo_id} is not 0-{MAX_ID} or {BROADCAST}")
        return self.frame(servo_id, code, bytes(params))

    # ------------------------------------------------------------------ requests

    def _field(self, value: int) -> bytes:
        return int(value).to_bytes(self.field_size, "little")

    def ping(self, servo_id: int) -> bytes:
        """Ping one servo."""
        return self.instruction(servo_id, PING)

    def read(self, servo_id: int, address: int, length: int) -> bytes:
        """Read ``length`` bytes of one servo's control table from ``address``."""
        return self.instruction(servo_id, READ, self._field(address) + self._field(length))

    def write(self, servo_id: int, address: int, data: bytes) -> bytes:
        """Write ``data`` into one servo's control table at ``address``."""
        return self.instruction(servo_id, WRITE, self._field(address) + bytes(data))

    def sync_read(self, address: int, length: int, ids: Sequence[int]) -> bytes:
        """Ask every servo in ``ids`` for ``length`` bytes from ``address``; each answers in turn."""
        params = self._field(address) + self._field(length) + bytes(ids)
        return self.instruction(BROADCAST, SYNC_READ, params)

    def sync_write(self, address: int, length: int, data: Mapping[int, bytes]) -> bytes:
        """Write each servo's ``length`` bytes at ``address`` in one packet (nobody answers)."""
        params = bytearray(self._field(address) + self._field(length))
        for servo_id, chunk in data.items():
            if len(chunk) != length:
                raise ValueError(f"servo {servo_id}: {len(chunk)} bytes for a {length}-byte write")
            params.append(servo_id)
            params += chunk
        return self.instruction(BROADCAST, SYNC_WRITE, bytes(params))

    # ------------------------------------------------------------------ reading requests

    def address_length(self, params: bytes) -> tuple[int, int]:
        """A read's (or a sync request's) address and length."""
        n = self.field_size
        if len(params) < 2 * n:
            raise ValueError(f"{len(params)} parameter bytes, expected address and length")
        return int.from_bytes(params[:n], "little"), int.from_bytes(params[n : 2 * n], "little")

    def sync_read_ids(self, params: bytes) -> tuple[int, int, list[int]]:
        """A sync read's address, length and ids, in the order they were listed."""
        address, length = self.address_length(params)
        return address, length, list(params[2 * self.field_size :])

    def sync_write_items(self, params: bytes) -> tuple[int, dict[int, bytes]]:
        """A sync write's address and each servo's data; ValueError when the data do not divide."""
        address, length = self.address_length(params)
        body = params[2 * self.field_size :]
        if length <= 0 or len(body) % (length + 1):
            raise ValueError(f"{len(body)} bytes do not divide into ids and {length}-byte data")
        return address, {
            body[i]: bytes(body[i + 1 : i + 1 + length]) for i in range(0, len(body), length + 1)
        }


def ids_text(ids: Iterable[int]) -> str:
    """``1, 2 and 3``: ids for a message."""
    items = [str(i) for i in ids]
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]
