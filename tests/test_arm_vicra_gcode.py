"""Marlin line format and reply parsing, against the reference's verified examples."""

from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.plugins.arms.common.framing import LineParser
from armtree.plugins.arms.vicra import gcode as G


def test_numbered_lines_match_reference_examples():
    # Marlin's line checksum (XOR, verified)
    assert G.numbered(0, "M110 N0") == "N0 M110 N0*125"
    assert G.numbered(1, "G28") == "N1 G28*18"
    assert G.numbered(2, "G1 X10 Y20 F3000") == "N2 G1 X10 Y20 F3000*77"
    assert G.numbered(3, "M114") == "N3 M114*36"


def test_host_line_verdicts():
    assert G.parse_host_line("N2 G1 X10 Y20 F3000*77") == G.HostLine(2, "G1 X10 Y20 F3000")
    assert G.parse_host_line("N2 G1 X10 Y20 F3000*78").problem == "checksum"
    assert G.parse_host_line("N2 G1 X10").problem == "no_checksum"
    assert G.parse_host_line("G28 ; home") == G.HostLine(None, "G28")
    assert G.words("G1 X10 Y-2.5 F3000") == ("G1", {"X": 10.0, "Y": -2.5, "F": 3000.0})
    assert G.words("g01 z5")[0] == "G1"


def test_replies():
    pos = G.parse_m114("X:0.00 Y:0.00 Z:0.00 E:0.00 Count X:0 Y:0 Z:0")
    assert pos.axes["X"] == 0 and pos.counts == {"X": 0, "Y": 0, "Z": 0}
    line = G.format_m114(12.5, -30.25, 100.0, (1000, -2420, 40000))
    assert line == "X:12.50 Y:-30.25 Z:100.00 E:0.00 Count X:1000 Y:-2420 Z:40000"
    assert G.parse_m114(line).axes == {"X": 12.5, "Y": -30.25, "Z": 100.0, "E": 0.0}
    assert G.parse_m114("echo:busy: processing") is None
    assert G.parse_endstop("x_min: TRIGGERED") == ("x_min", True)
    assert G.parse_endstop("z_max: open") == ("z_max", False)
    assert G.parse_resend("Resend: 4") == 4 and G.parse_resend("rs N7") == 7
    assert G.is_ok("ok") and G.is_ok("ok N4 P15 B3") and not G.is_ok("okay")


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=80))
def test_any_host_line_parses_without_exception(text):
    line = G.parse_host_line(text)
    G.words(line.command)
    G.parse_m114(text)
    G.parse_endstop(text)
    G.parse_resend(text)


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 10**6), st.text(alphabet="GMXYZF0123456789. -", max_size=40))
def test_numbered_round_trip(n, command):
    command = command.strip()
    line = G.parse_host_line(G.numbered(n, command))
    assert line.problem is None and line.number == n and line.command == " ".join([command]).strip()


@settings(max_examples=200, deadline=None)
@given(st.lists(st.binary(max_size=300), max_size=10))
def test_reply_stream_never_grows_unbounded(chunks):
    parser = LineParser(max_line=256)
    for chunk in chunks:
        for line in parser.feed(chunk):
            G.parse_m114(line)
            G.parse_resend(line)
        assert parser.buffered < 256


NUMBER = st.floats(-1000, 1000, allow_nan=False).map(lambda v: f"{v:.2f}")
GCODE = st.builds(
    lambda code, args, n: (
        (G.numbered(n, f"{code} {' '.join(args)}") if n >= 0 else f"{code} {' '.join(args)}") + "\n"
    ),
    st.sampled_from(
        [
            "G0",
            "G1",
            "G4",
            "G28",
            "G90",
            "G91",
            "G92",
            "M114",
            "M119",
            "M280",
            "M400",
            "M410",
            "M106",
            "M107",
            "M110",
            "M115",
            "M18",
            "X5",
        ]
    ),
    st.lists(st.builds(lambda a, v: a + v, st.sampled_from("XYZFPSNR"), NUMBER), max_size=4),
    st.integers(-1, 6),
).map(str.encode)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(st.binary(max_size=200), GCODE), max_size=10))
def test_marlin_emulator_and_driver_take_any_bytes(chunks):
    import numpy as np

    from armtree.api.clock import VirtualClock
    from armtree.plugins.arms.vicra.driver import VicraDriver
    from armtree.plugins.arms.vicra.emulator import MarlinEmulator
    from armtree.plugins.arms.vicra.kinematics import VicraModel

    model = VicraModel()
    emulator = MarlinEmulator(model, VirtualClock())  # not started: replies go nowhere
    driver = VicraDriver(model, "/dev/null", clock=VirtualClock())
    for i, chunk in enumerate(chunks):
        emulator.on_bytes(chunk, 0.1 * i)
        emulator.on_timer(0.1 * i + 0.05)
        driver.on_data(chunk)
        assert sum(len(x) for x in emulator._rx) <= 128
        assert len(emulator._ring) <= 4
        assert len(driver.banner) <= 64
    assert np.all(np.isfinite(emulator.true_joints()))
