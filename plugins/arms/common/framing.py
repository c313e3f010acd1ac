"""Resynchronising parsers for serial byte streams, and recognising a foreign protocol.

Every parser takes arbitrary chunks through :meth:`feed` and returns the
complete frames found so far. Bytes that cannot start a valid frame are
skipped (counted in ``discarded``), a frame that fails its check makes the
parser resume one byte after its start, and the internal buffer never holds
more than one frame's worth of bytes, so any byte stream gives frames or
resynchronisation, never an exception or an unbounded buffer.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable


class _HeaderSyncParser(ABC):
    """Frames that start with ``header``: the scan, resynchronisation and counting they share.

    A subclass says how long the frame at the start of the buffer is
    (:meth:`_frame_length`) and whether a complete one is valid (:meth:`_valid`).
    """

    def __init__(self, header: bytes, check: Callable[[bytes], bool] | None) -> None:
        self.header = header
        self.check = check
        self.discarded = 0
        self._buf = bytearray()

    @property
    def buffered(self) -> int:
        """Bytes held waiting for the rest of a frame."""
        return len(self._buf)

    @abstractmethod
    def _frame_length(self, buf: bytearray) -> int | None:
        """Length of the frame starting at ``buf[0]``; None: more bytes needed; 0: no frame."""

    def _valid(self, frame: bytes) -> bool:
        return self.check is None or self.check(frame)

    def feed(self, data: bytes) -> list[bytes]:
        """Add bytes; return every complete valid frame in order."""
        frames: list[bytes] = []
        buf = self._buf
        buf.extend(data)
        while True:
            start = buf.find(self.header)
            if start < 0:
                # Keep a possible partial header at the end.
                keep = _partial_suffix(buf, self.header)
                self.discarded += len(buf) - keep
                del buf[: len(buf) - keep]
                break
            if start:
                self.discarded += start
                del buf[:start]
            total = self._frame_length(buf)
            if total is None or len(buf) < total:
                break
            frame = bytes(buf[:total])
            if total and self._valid(frame):
                frames.append(frame)
                del buf[:total]
            else:
                self.discarded += 1
                del buf[:1]
        return frames

    def reset(self) -> None:
        """Forget any partial frame."""
        self._buf.clear()


class FixedFrameParser(_HeaderSyncParser):
    """Fixed-length frames: ``header`` ... ``tail`` in exactly ``length`` bytes.

    ``check(frame) -> bool`` may add a validity test (a checksum); it must not raise.
    The buffer always holds fewer than ``length`` bytes between calls.
    """

    def __init__(
        self,
        header: bytes,
        length: int,
        tail: bytes = b"",
        check: Callable[[bytes], bool] | None = None,
    ) -> None:
        if not header or length < len(header) + len(tail):
            raise ValueError("a frame needs a header and room for its tail")
        super().__init__(header, check)
        self.length = length
        self.tail = tail

    def _frame_length(self, buf: bytearray) -> int:
        return self.length

    def _valid(self, frame: bytes) -> bool:
        return (not self.tail or frame.endswith(self.tail)) and super()._valid(frame)


class LengthPrefixedParser(_HeaderSyncParser):
    """Frames ``header + len + payload(len) + trailer(trailer_len)`` with a check.

    ``len_offset`` is the index of the one-byte payload length after the
    header's start; ``max_payload`` bounds it; ``check(frame) -> bool`` validates
    a complete frame (e.g. the Magician's checksum). A failed check resumes one
    byte after the header, as firmware that ignores a bad frame does.
    """

    def __init__(
        self,
        header: bytes,
        trailer_len: int,
        check: Callable[[bytes], bool],
        max_payload: int = 255,
    ) -> None:
        super().__init__(header, check)
        self.trailer_len = trailer_len
        self.max_payload = max_payload

    def _frame_length(self, buf: bytearray) -> int | None:
        h = len(self.header)
        if len(buf) < h + 1:
            return None
        n = buf[h]
        if n > self.max_payload:
            return 0
        return h + 1 + n + self.trailer_len


class CountedLengthParser(_HeaderSyncParser):
    """Frames whose length field counts the bytes after it: servo bus packets.

    The frame starting with ``header`` holds a little-endian length of
    ``length_size`` bytes at ``length_at`` (counted from the header's start)
    and ends ``length`` bytes after that field: Feetech's ``FF FF ID LEN ...``
    (``length_at=3``) and Dynamixel 2.0's ``FF FF FD 00 ID LEN_L LEN_H ...``
    (``length_at=5``, two bytes). A length outside ``min_length..max_length``
    cannot start a frame; ``check(frame) -> bool`` validates a complete one
    (its checksum or CRC) and must not raise.
    """

    def __init__(
        self,
        header: bytes,
        length_at: int,
        check: Callable[[bytes], bool],
        *,
        length_size: int = 1,
        min_length: int = 0,
        max_length: int = 255,
    ) -> None:
        if length_at < len(header) or length_size not in (1, 2):
            raise ValueError("the length field follows the header and is one or two bytes")
        super().__init__(header, check)
        self.length_at = length_at
        self.length_size = length_size
        self.min_length = min_length
        self.max_length = max_length

    def _frame_length(self, buf: bytearray) -> int | None:
        end = self.length_at + self.length_size
        if len(buf) < end:
            return None
        n = int.from_bytes(buf[self.length_at : end], "little")
        if not self.min_length <= n <= self.max_length:
            return 0
        return end + n


class LineParser:
    """Text lines ending in ``\\n`` (``\\r`` stripped), for G-code and Marlin replies.

    A line longer than ``max_line`` bytes is cut there and returned as is, so
    binary noise cannot grow the buffer. Undecodable bytes become U+FFFD.
    """

    def __init__(self, max_line: int = 256) -> None:
        self.max_line = max_line
        self.discarded = 0
        self._buf = bytearray()

    @property
    def buffered(self) -> int:
        """Bytes of the unfinished line."""
        return len(self._buf)

    def feed(self, data: bytes) -> list[str]:
        """Add bytes; return every complete line without its terminator."""
        lines: list[str] = []
        buf = self._buf
        for byte in data:
            if byte == 0x0A:
                lines.append(buf.decode("utf-8", "replace").rstrip("\r"))
                buf.clear()
            else:
                buf.append(byte)
                if len(buf) >= self.max_line:
                    lines.append(buf.decode("utf-8", "replace"))
                    self.discarded += len(buf)
                    buf.clear()
        return lines

    def reset(self) -> None:
        """Forget the unfinished line."""
        self._buf.clear()


def _partial_suffix(buf: bytearray, header: bytes) -> int:
    """Length of the longest suffix of ``buf`` that is a proper prefix of ``header``."""
    for k in range(min(len(header) - 1, len(buf)), 0, -1):
        if buf[-k:] == header[:k]:
            return k
    return 0


#: Text a board prints at start-up, and what it means, for wrong-protocol errors.
_BANNERS: tuple[tuple[bytes, str], ...] = (
    (b"marlin", "a Marlin G-code board (Mega + RAMPS, e.g. the VICRA arm)"),
    (b"echo:", "a Marlin G-code board (Mega + RAMPS, e.g. the VICRA arm)"),
    (b"start\n", "a Marlin G-code board (Mega + RAMPS, e.g. the VICRA arm)"),
    (b"grbl", "a GRBL G-code board"),
    (b"ssc32", "an SSC-32 servo controller"),
    (b"ok\n", "a G-code board answering 'ok'"),
)


def identify_foreign_protocol(data: bytes) -> str | None:
    """Name the device that sent ``data`` when it is recognisably not what was expected.

    Recognises Marlin and GRBL banners, SSC-32 version strings, Dobot Magician
    frames (``AA AA``) and Dobot V1 status frames (``A5 ... 5A`` 42 bytes apart).
    Returns None when nothing is recognised.
    """
    low = data.lower()
    for marker, what in _BANNERS:
        if marker in low:
            return what
    if b"\xaa\xaa" in data:
        return "a Dobot Magician (0xAA 0xAA frames)"
    start = data.find(b"\xa5")
    while 0 <= start <= len(data) - 42:
        if data[start + 41] == 0x5A:
            return "a Dobot V1.0 with its original firmware (42-byte status frames)"
        start = data.find(b"\xa5", start + 1)
    return None
