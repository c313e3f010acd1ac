"""The pty emulator's packet mode: data arrives unchanged, a port open is reported.

pyserial's ``open()`` flushes the port's input; the master side sees that as a
``TIOCPKT_FLUSHREAD`` control report, the emulator's stand-in for the DTR line
a pty does not carry.
"""

from __future__ import annotations

import os
import time

import numpy as np
import pytest
import serial
from hypothesis import given, settings
from hypothesis import strategies as st
from test_arm_common_pty import OneJoint, ToyEmulator

from armtree.api.clock import VirtualClock
from armtree.plugins.arms.common.pty_emulator import (
    TIOCPKT_DATA,
    TIOCPKT_FLUSHREAD,
    parse_packet,
)


class OpenCountingEmulator(ToyEmulator):
    """The toy firmware without its status stream, recording every open and every byte received."""

    def next_event_time(self):
        return None

    def on_timer(self, t):
        pass

    def on_start(self):
        super().on_start()
        self.opened: list[float] = []
        self.received = bytearray()

    def on_port_opened(self, t):
        self.opened.append(t)

    def on_bytes(self, data, t):
        self.received.extend(data)
        super().on_bytes(data, t)


def test_a_data_read_is_the_bytes_after_the_status_byte():
    assert parse_packet(bytes([TIOCPKT_DATA]) + b"abc") == (0, b"abc")
    assert parse_packet(bytes([TIOCPKT_DATA]) + b"\x01\x00") == (0, b"\x01\x00")
    assert parse_packet(bytes([TIOCPKT_DATA])) == (0, b"")
    assert parse_packet(b"") == (0, b"")


def test_a_control_read_carries_flags_and_no_data():
    assert parse_packet(bytes([TIOCPKT_FLUSHREAD])) == (TIOCPKT_FLUSHREAD, b"")
    assert parse_packet(bytes([TIOCPKT_FLUSHREAD | 0x02])) == (TIOCPKT_FLUSHREAD | 0x02, b"")


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.one_of(
            st.binary(min_size=1, max_size=64),  # a data read
            st.integers(min_value=1, max_value=255),  # a control report
        ),
        max_size=30,
    )
)
def test_data_bytes_arrive_unchanged_however_the_reads_split_them(reads):
    chunks = [bytes([TIOCPKT_DATA]) + r if isinstance(r, bytes) else bytes([r]) for r in reads]
    parsed = [parse_packet(c) for c in chunks]
    assert b"".join(data for _, data in parsed) == b"".join(
        r for r in reads if isinstance(r, bytes)
    )
    assert [flags for flags, _ in parsed if flags] == [r for r in reads if isinstance(r, int)]


def _wait_for(predicate, emu, timeout=5.0):
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, "the emulator never saw it"
        emu.step(emu.time)
        time.sleep(0.005)


@pytest.fixture
def opened():
    """An emulator on a pty, a pyserial port opened on it, and the open seen."""
    emu = OpenCountingEmulator(OneJoint(), VirtualClock())
    path = emu.start()
    emu.step(0.0)
    assert emu.opened == [] and emu.port_opens == 0
    port = serial.Serial(path, 9600, timeout=0.05)
    try:
        _wait_for(lambda: emu.port_opens == 1, emu)
        yield emu, port
    finally:
        port.close()
        emu.close()


def test_opening_the_port_is_reported_once_and_written_bytes_arrive_unchanged(opened):
    emu, port = opened
    assert emu.opened == [emu.time]
    # every byte value, in writes the pty may split or merge, and a 0 byte first
    payload = bytes(range(256)) * 20
    for k in range(0, len(payload), 700):
        port.write(payload[k : k + 700])
    _wait_for(lambda: len(emu.received) >= len(payload), emu)
    assert bytes(emu.received) == payload
    assert emu.port_opens == 1, "writing is no open"
    port.close()
    second = serial.Serial(emu.path, 9600, timeout=0.05)
    second.close()
    _wait_for(lambda: emu.port_opens == 2, emu)
    assert len(emu.opened) == 2 and bytes(emu.received) == payload


def test_the_host_reads_what_the_emulator_sends_unchanged(opened):
    emu, port = opened
    emu.send(b"\x00\x01status\x00")
    got = b""
    deadline = time.monotonic() + 5.0
    while len(got) < 9 and time.monotonic() < deadline:
        got += port.read(64)
    assert got == b"\x00\x01status\x00"


def test_a_write_from_the_master_side_is_not_mistaken_for_host_data(opened):
    # tests inject noise by writing to the master fd: it goes to the host, never back
    emu, port = opened
    os.write(emu._master, b"noise")
    assert port.read(5) == b"noise"
    emu.step(emu.time)
    assert bytes(emu.received) == b"" and np.isfinite(emu.time)
