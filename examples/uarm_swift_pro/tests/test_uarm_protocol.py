"""The G-code dialect as text: what the host writes and how the firmware reads it, and replies."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from armtree_uarm_swift_pro import protocol as P


def test_the_firmware_reads_lines_as_protocol_c_does():
    assert P.read_host_line("#12 g0 x200 (a comment) y0 ;the rest") == P.HostLine(12, "G0X200Y0")
    assert P.read_host_line("M2231 V1") == P.HostLine(None, "M2231V1")
    assert P.read_host_line("#5 hello") is None  # not G, M, P or S: ignored
    assert P.read_host_line("") is None
    assert P.split_command("G0X200.5Y-3Z150F100") == (
        "G0",
        {"X": 200.5, "Y": -3.0, "Z": 150.0, "F": 100.0},
    )


def test_replies_parse_as_the_sdk_reads_them():
    reply = P.parse_reply("$5 ok X200.0000 Y0.0000 Z150.0000")
    assert reply == P.Reply(5, "OK", ("X200.0000", "Y0.0000", "Z150.0000"))
    assert reply.ok and reply.value("Y") == 0.0
    assert P.parse_reply("$7 E22") == P.Reply(7, "E22")
    assert P.parse_reply("$9") == P.Reply(9, "")  # a Grbl error without a code
    assert P.parse_reply("@3 X1 Y2") is None
    assert P.parse_event("@3 X200.0000 Y0.0000 Z150.0000 R90.0000") == (
        3,
        {"X": 200.0, "Y": 0.0, "Z": 150.0, "R": 90.0},
    )
    assert P.reply(4, "ok", "V1") == "$4 ok V1\n" and P.reply(None, "ok") == "ok\n"


def test_line_numbers_run_to_9999_and_start_again():
    assert P.next_number(1) == 2 and P.next_number(9999) == 1
    assert P.command(42, "P2200") == "#42 P2200\n"


@given(st.floats(-9999.9999, 9999.9999, allow_nan=False))
def test_numbers_fit_the_firmwares_ten_byte_buffer(value):
    text = P.number(value)
    assert len(text) <= 10
    assert abs(float(text) - value) <= 5.1e-5
