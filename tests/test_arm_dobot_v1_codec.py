"""Dobot V1 42-byte frames: byte-exact against the reference's vectors, and resync."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from armtree.plugins.arms.dobot_v1 import codec


def _hex(s: str) -> bytes:
    return bytes.fromhex(s)


# vectors computed with struct.pack('<f') (Dobot protocol frame layout)
MOVE_200 = _hex(
    "A5 00 00 40 40 00 00 00 00 00 00 48 43 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 "
    "00 00 80 3F 00 00 00 00 00 00 00 00 5A"
)
JOG_J1 = _hex(
    "A5 00 00 00 40 00 00 80 3F 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 "
    "00 00 48 42 00 00 00 00 00 00 00 00 5A"
)


def test_state3_vector():
    cmd = codec.move_xyz([200.0, 0.0, 0.0], mode=codec.MODE_MOVJ)
    assert cmd.encode() == MOVE_200
    assert codec.Command.decode(MOVE_200) == cmd


def test_state2_jog_vector():
    assert codec.jog(1, 50.0).encode() == JOG_J1


def test_status_round_trip_and_first_power_up_example():
    status = codec.Status(291.05, 0.0, -33.79, 0.0, 0.0, 10.0, 50.0, 0.0, 1.0, 0.0)
    raw = status.encode()
    assert len(raw) == 42 and raw[0] == 0xA5 and raw[-1] == 0x5A
    back = codec.Status.decode(raw)
    assert back.x == pytest.approx(291.05, abs=1e-4) and back.is_grab == 1.0
    assert back.joints == (0.0, 10.0, 50.0)
    assert raw[1:5] == struct.pack("<f", 291.05)


def test_bad_frames_are_refused():
    with pytest.raises(ValueError):
        codec.decode_frame(b"\xa5" + bytes(40) + b"\x00")
    with pytest.raises(ValueError):
        codec.encode_frame([0.0] * 11)


@given(st.lists(st.binary(max_size=90), max_size=20))
def test_any_byte_stream_gives_frames_or_resync(chunks):
    parser = codec.frame_parser()
    for chunk in chunks:
        for frame in parser.feed(chunk):
            codec.decode_frame(frame)
        assert parser.buffered < 42


@given(
    st.binary(max_size=80), st.lists(st.floats(width=32, allow_nan=False), min_size=10, max_size=10)
)
def test_frame_found_after_noise(noise, values):
    frame = codec.encode_frame(values)
    parser = codec.frame_parser()
    got = parser.feed(noise.replace(b"\xa5", b"") + frame)
    assert got == [frame]
    assert list(codec.decode_frame(got[0])) == values
