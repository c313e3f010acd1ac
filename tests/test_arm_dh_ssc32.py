"""SSC-32 commands and the least-squares pulse-to-angle map of Aceves slides."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.errors import ConfigError
from armtree.plugins.arms.dh import ssc32 as S


def test_seed_001_servo_example_is_fitted_exactly():
    # Aceves slides: PWM 0.3 ms -> 170 deg, 1.2 ms -> 85 deg, 2.1 ms -> 0 deg
    m = S.ServoMap.fit(0, [[300, 170], [1200, 85], [2100, 0]])
    assert m.slope == pytest.approx(-85 / 900)
    assert m.angle(1200) == pytest.approx(85)
    assert m.pulse(0) == pytest.approx(2100)
    assert m.residual == pytest.approx(0, abs=1e-9)


def test_noisy_table_fit_is_least_squares():
    rng = np.random.default_rng(0)
    pulses = np.linspace(600, 2400, 25)
    angles = 0.09 * pulses - 135 + rng.normal(0, 0.5, pulses.size)
    m = S.ServoMap.fit(3, np.column_stack([pulses, angles]))
    ref = np.polyfit(pulses, angles, 1)
    assert (m.slope, m.intercept) == pytest.approx(tuple(ref))
    assert 0.3 < m.residual < 0.7


def test_commands_are_byte_exact():
    assert S.move_command({1: 1600, 0: 1500}, 1000) == b"#0P1500#1P1600T1000\r"
    assert S.query_pulses([0, 5]) == b"QP0 QP5\r"
    assert S.QUERY_MOTION == b"Q\r"
    assert S.stop_command([2]) == b"STOP2\r"
    with pytest.raises(ValueError):
        S.move_command({0: 2600})


def test_parse_request():
    r = S.parse_request("#0 P1500 S750 #1P1600T1000")
    assert r.moves == {0: (1500, 750.0), 1: (1600, None)} and r.time_ms == 1000
    assert S.parse_request("QP0 QP12 Q").queries == (("QP", 0), ("QP", 12), ("Q", None))
    assert S.parse_request("VER").version
    assert S.parse_request("STOP 4").stops == (4,)


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=60))
def test_any_request_text_parses(text):
    S.parse_request(text)


def test_servo_config():
    maps = S.servo_maps_from_config(None, 2)
    assert [m.channel for m in maps] == [0, 1] and maps[0].angle(1500) == pytest.approx(0, abs=1e-9)
    maps = S.servo_maps_from_config([{"channel": 4, "table": [[500, -90], [2500, 90]]}], 1)
    assert maps[0].channel == 4 and maps[0].range() == pytest.approx((-90, 90))
    for bad, match in [
        ([{"table": [[1, 2]]}], "table"),
        ([{"channel": 40, "table": [[500, 0], [600, 1]]}], "channel"),
        ([], "one servo per joint"),
        ([{"table": [[500, 0], [500, 1]]}], "different"),
    ]:
        with pytest.raises(ConfigError, match=match):
            S.servo_maps_from_config(bad, 1)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.binary(max_size=120), max_size=8))
def test_board_emulator_and_driver_take_any_bytes(chunks):
    from armtree.api.clock import VirtualClock
    from armtree.plugins.arms.dh.driver import SSC32Driver
    from armtree.plugins.arms.dh.emulator import SSC32Emulator
    from armtree.plugins.arms.dh.kinematics import DHModel, DHRow

    model = DHModel([DHRow(0, 0, 0), DHRow(100, 0, 0)], [(-90, 90)] * 2, "modified")
    maps = S.servo_maps_from_config(None, 2)
    emulator = SSC32Emulator(model, VirtualClock(), maps)  # not started: replies go nowhere
    driver = SSC32Driver(model, "/dev/null", maps, clock=VirtualClock())
    driver.version = S.VERSION  # past the handshake: replies to queries are expected
    for i, chunk in enumerate(chunks):
        emulator.on_bytes(chunk, 0.1 * i)
        driver.on_time(0.1 * i)  # a query goes out (nowhere) and its reply is awaited
        driver.on_data(chunk)
        assert len(emulator._buf) <= 256 and len(driver._buf) <= 256
    pulses = emulator.pulses(10.0)
    assert np.all((pulses >= S.PULSE_MIN) & (pulses <= S.PULSE_MAX))


def test_group_moves_arrive_together_at_the_slowest_speed():
    from armtree.api.clock import VirtualClock
    from armtree.plugins.arms.dh.emulator import SSC32Emulator
    from armtree.plugins.arms.dh.kinematics import DHModel, DHRow

    model = DHModel([DHRow(0, 0, 0), DHRow(100, 0, 0)], [(-90, 90)] * 2, "modified")
    emulator = SSC32Emulator(model, VirtualClock(), S.servo_maps_from_config(None, 2))
    start = emulator.pulses(0.0)[:2].copy()
    np.testing.assert_allclose(start, [1500, 1500])
    # channel 0 at 500 us/s over 500 us (1 s), channel 1 over 100 us: both take 1 s
    emulator.on_bytes(b"#0P2000S500#1P1600\r", 0.0)
    np.testing.assert_allclose(emulator.pulses(0.5)[:2], [1750, 1550])
    np.testing.assert_allclose(emulator.pulses(1.0)[:2], [2000, 1600])
    # T stretches a group move; STOP freezes a channel where it is
    emulator.on_bytes(b"#0P1000T2000\r", 1.0)
    emulator.on_bytes(b"STOP0\r", 2.0)
    assert emulator.pulses(5.0)[0] == pytest.approx(1500)
    # a digital output for a pump, and ESC cancels a half-typed line
    emulator.suction_channel = 7
    emulator.on_bytes(b"#7H\r#1P900\x1b\r", 5.0)
    assert emulator.tool().suction and emulator.pulses(9.0)[1] == pytest.approx(1600)
