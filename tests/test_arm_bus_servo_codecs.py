"""The two servo bus protocols byte for byte: Feetech STS/SCS and Dynamixel Protocol 2.0.

Fixed vectors come from the protocols' documents (the Feetech checksum rule applied to
the packets the SO-101's users send; the ROBOTIS Protocol 2.0 e-manual's examples); the
property tests hold the codecs against the vendors' own Python SDKs, which a user's
program would use, and against themselves (round trips, resynchronisation on noise).
"""

from __future__ import annotations

import pytest
import scservo_sdk
from dynamixel_sdk.protocol2_packet_handler import Protocol2PacketHandler
from hypothesis import given
from hypothesis import strategies as st

from armtree.plugins.arms.bus_servo import bus, dynamixel, feetech
from armtree.plugins.arms.bus_servo.bus import TWOS, UNSIGNED, PacketReader, decode_value
from armtree.plugins.arms.bus_servo.bus import encode_value as enc
from armtree.plugins.arms.bus_servo.dynamixel import Dynamixel, crc16, stuff, unstuff
from armtree.plugins.arms.bus_servo.feetech import Feetech

FT = Feetech()
DXL = Dynamixel()
ids = st.integers(0, bus.MAX_ID)
payloads = st.binary(max_size=64)


# ---------------------------------------------------------------------------- Feetech


@pytest.mark.parametrize(
    ("packet", "expected"),
    [
        (FT.ping(1), "ff ff 01 02 01 fb"),
        (FT.read(1, 56, 2), "ff ff 01 04 02 38 02 be"),  # present position of id 1
        (FT.write(1, 42, (2048).to_bytes(2, "little")), "ff ff 01 05 03 2a 00 08 c4"),
        (FT.write(1, 40, b"\x01"), "ff ff 01 04 03 28 01 ce"),  # torque on
    ],
)
def test_feetech_packets_are_the_documented_bytes(packet, expected):
    assert packet.hex(" ") == expected


def test_feetech_sync_packets_follow_the_length_rule():
    write = FT.sync_write(42, 2, {1: b"\x00\x08", 2: b"\xff\x07"})
    assert write[:5] == bytes([0xFF, 0xFF, 0xFE, (2 + 1) * 2 + 4, 0x83])
    assert write[5:7] == bytes([42, 2]) and write[7:13] == bytes([1, 0, 8, 2, 0xFF, 7])
    read = FT.sync_read(56, 2, [1, 2, 3])
    assert read.hex(" ") == "ff ff fe 07 82 38 02 01 02 03 " + f"{feetech.checksum(read[2:-1]):02x}"
    with pytest.raises(ValueError, match="2-byte write"):
        FT.sync_write(42, 2, {1: b"\x00"})


@given(ids, st.integers(0, 255), st.binary(max_size=40))
def test_feetech_checksum_agrees_with_the_sdk(servo_id, code, params):
    packet = FT.frame(servo_id, code, params)
    # scservo_sdk's txPacket fills in the header and checksum of a packet it is handed
    sdk = [0, 0, servo_id, len(params) + 2, code, *params, 0]

    class Port:
        is_using = False
        written = b""

        def clearPort(self):
            pass

        def writePort(self, data):
            Port.written = bytes(data)
            return len(data)

    assert scservo_sdk.PacketHandler(0).txPacket(Port(), sdk) == scservo_sdk.COMM_SUCCESS
    assert Port.written == packet


@given(ids, st.integers(0, 0x7F), st.binary(max_size=40), st.binary(max_size=20))
def test_feetech_status_round_trips_through_noise(servo_id, error, data, noise):
    reader = PacketReader(FT, status=True)
    status = FT.status(servo_id, error, data)
    got = reader.feed(noise.replace(b"\xff", b"") + status)
    assert got == [bus.Packet(servo_id, None, error, data)]


@given(st.binary(min_size=6, max_size=40), st.integers(0, 10_000))
def test_a_feetech_packet_with_a_flipped_bit_is_never_taken_for_itself(body, where):
    packet = FT.instruction(1, bus.WRITE, body)
    i = 2 + where % (len(packet) - 2)
    bad = bytearray(packet)
    bad[i] ^= 1 << (where % 8)
    reader = PacketReader(FT, status=False)
    assert bus.Packet(1, bus.WRITE, 0, body) not in reader.feed(bytes(bad))


@given(st.integers(-2047, 2047))
def test_sign_magnitude_matches_the_feetech_sdk(value):
    # scservo_sdk's SCS_TOSCS / SCS_TOHOST code a signed value with its sign in a given bit
    raw = enc(value, 2, 11)
    assert int.from_bytes(raw, "little") == scservo_sdk.SCS_TOSCS(value, 11)
    assert decode_value(raw, 11) == scservo_sdk.SCS_TOHOST(int.from_bytes(raw, "little"), 11)
    assert decode_value(enc(value * 16, 2, 15), 15) == value * 16


def test_sign_magnitude_edges():
    assert enc(-100, 2, 11) == (0x0864).to_bytes(2, "little")
    assert decode_value(b"\x00\x80", 15) == 0  # minus zero is zero
    with pytest.raises(ValueError, match="sign-magnitude"):
        enc(2048, 2, 11)  # lerobot #1296: a homing offset beyond the 11 bits
    assert enc(4095, 2, UNSIGNED, "big") == b"\x0f\xff"  # SCS servos are big-endian


# ---------------------------------------------------------------------------- Dynamixel


@pytest.mark.parametrize(
    ("packet", "expected"),
    [
        (DXL.ping(1), "ff ff fd 00 01 03 00 01 19 4e"),
        (DXL.read(1, 132, 4), "ff ff fd 00 01 07 00 02 84 00 04 00 1d 15"),
        (DXL.write(1, 116, (512).to_bytes(4, "little")), "ff ff fd 00 01 09 00 03 74 00 00 02 00 00 ca 89"),
        (DXL.status(1, 0, bytes([0x06, 0x04, 0x26])), "ff ff fd 00 01 07 00 55 00 06 04 26 65 5d"),
    ],
)  # fmt: skip
def test_dynamixel_packets_are_the_e_manual_examples(packet, expected):
    assert packet.hex(" ") == expected


@given(st.binary(max_size=200))
def test_crc16_agrees_with_the_sdk(data):
    assert crc16(data) == Protocol2PacketHandler().updateCRC(0, list(data), len(data))


@given(payloads)
def test_unstuffing_undoes_stuffing(payload):
    stuffed = stuff(payload)
    assert unstuff(stuffed) == payload
    assert b"\xff\xff\xfd" not in stuffed.replace(b"\xff\xff\xfd\xfd", b"")


@given(ids, st.integers(0, 255), st.lists(st.sampled_from([0xFF, 0xFD, 0x00, 0x55]), max_size=30))
def test_stuffed_packets_are_the_sdks(servo_id, code, params):
    packet = DXL.frame(servo_id, code, bytes(params))
    sdk = [0] * 7 + [code, *params, 0, 0]
    sdk[4], sdk[5], sdk[6] = servo_id, (len(params) + 3) & 0xFF, (len(params) + 3) >> 8
    # The SDK's addStuffing returns the stuffed packet (its txPacket drops it when the
    # length grows, and sends the packet unstuffed: the emulator reads those too)
    stuffed = bytes(Protocol2PacketHandler().addStuffing(sdk))
    assert stuffed[4:-2] == packet[4:-2]
    assert crc16(packet[:-2]) == int.from_bytes(packet[-2:], "little")


@given(ids, st.integers(0, 255), payloads, st.binary(max_size=30))
def test_dynamixel_status_round_trips_through_noise(servo_id, error, data, noise):
    reader = PacketReader(DXL, status=True)
    got = reader.feed(noise.replace(b"\xff", b"") + DXL.status(servo_id, error, data))
    assert got == [bus.Packet(servo_id, None, error, data)]


@given(st.integers(-(2**31), 2**31 - 1))
def test_twos_complement_values_round_trip(value):
    assert decode_value(enc(value, 4, TWOS), TWOS) == value


def test_sync_requests_decode_as_they_were_built():
    for proto in (FT, DXL):
        reader = PacketReader(proto, status=False)
        (read,) = reader.feed(proto.sync_read(132, 10, [3, 1, 2]))
        assert read.id == bus.BROADCAST and read.instruction == bus.SYNC_READ
        assert proto.sync_read_ids(read.params) == (132, 10, [3, 1, 2])
        (write,) = reader.feed(proto.sync_write(112, 8, {1: bytes(8), 5: bytes(range(8))}))
        assert proto.sync_write_items(write.params) == (112, {1: bytes(8), 5: bytes(range(8))})


def test_error_bytes_are_named():
    assert feetech.error_names(0x20 | 0x04) == ["overheat", "overload"]
    assert dynamixel.error_names(dynamixel.ALERT, 0x20) == ["overload"]
    assert dynamixel.error_names(7) == ["access error"]
