"""Resynchronising parsers: any byte stream gives frames or resynchronisation."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from armtree.plugins.arms.common import (
    FixedFrameParser,
    LengthPrefixedParser,
    LineParser,
    identify_foreign_protocol,
)


def _xor_ok(frame: bytes) -> bool:
    return (sum(frame[3:-1]) & 0xFF) == frame[-1]


def _magician_like(payload: bytes) -> bytes:
    return b"\xaa\xaa" + bytes([len(payload)]) + payload + bytes([sum(payload) & 0xFF])


@given(st.lists(st.binary(max_size=64), max_size=30))
def test_fixed_parser_never_raises_and_stays_bounded(chunks):
    p = FixedFrameParser(b"\xa5", 42, b"\x5a")
    for chunk in chunks:
        for frame in p.feed(chunk):
            assert len(frame) == 42 and frame[0] == 0xA5 and frame[-1] == 0x5A
        assert p.buffered < 42


@given(st.binary(max_size=100), st.binary(min_size=40, max_size=40), st.binary(max_size=100))
def test_fixed_parser_finds_a_frame_after_garbage(before, body, after):
    frame = b"\xa5" + body + b"\x5a"
    clean = before.replace(b"\xa5", b"")
    stream = clean + frame + after
    p = FixedFrameParser(b"\xa5", 42, b"\x5a")
    got = []
    for i in range(0, len(stream), 7):
        got += p.feed(stream[i : i + 7])
    assert got[0] == frame
    assert p.discarded >= len(clean)


@given(st.lists(st.binary(max_size=40), max_size=30))
def test_length_prefixed_parser_never_raises_and_stays_bounded(chunks):
    p = LengthPrefixedParser(b"\xaa\xaa", 1, _xor_ok, max_payload=64)
    for chunk in chunks:
        for frame in p.feed(chunk):
            assert _xor_ok(frame)
        assert p.buffered <= 2 + 1 + 64 + 1


@given(st.binary(max_size=60), st.binary(min_size=1, max_size=30))
def test_length_prefixed_parser_recovers_a_valid_frame(garbage, payload):
    frame = _magician_like(payload)
    p = LengthPrefixedParser(b"\xaa\xaa", 1, _xor_ok, max_payload=64)
    clean = garbage.replace(b"\xaa", b"")
    assert p.feed(clean + frame + frame) == [frame, frame]


def test_length_prefixed_parser_skips_a_bad_checksum():
    good = _magician_like(b"\x0a\x00")
    bad = bytearray(good)
    bad[-1] ^= 0xFF
    p = LengthPrefixedParser(b"\xaa\xaa", 1, _xor_ok)
    assert p.feed(bytes(bad) + good) == [good]
    assert p.discarded > 0


@given(st.lists(st.binary(max_size=300), max_size=10))
def test_line_parser_bounded(chunks):
    p = LineParser(max_line=64)
    for chunk in chunks:
        p.feed(chunk)
        assert p.buffered < 64


def test_line_parser_splits_lines_and_strips_cr():
    p = LineParser()
    assert p.feed(b"ok\r\nstart\npar") == ["ok", "start"]
    assert p.feed(b"tial\n") == ["partial"]


def test_identify_foreign_protocol():
    assert "Marlin" in identify_foreign_protocol(b"start\necho: External Reset\n")
    assert "Magician" in identify_foreign_protocol(b"\xaa\xaa\x02\x0a\x00\xf6")
    v1 = b"\xa5" + bytes(40) + b"\x5a"
    assert "V1.0" in identify_foreign_protocol(b"\x00" + v1)
    assert identify_foreign_protocol(b"\x00\x01\x02") is None
