"""The Duckybot: unicycle model (Pozzani 2023 eqs. 5-6) and Lyapunov tracking (eqs. 7-8)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.plugins.sim.duckybot import (
    Duckybot,
    DuckybotParams,
    Leg,
    UnicycleState,
    lyapunov_control,
    unicycle_step,
)


def test_unicycle_straight_and_turning_on_the_spot():
    s = unicycle_step(UnicycleState(0, 0, math.pi / 2), 50.0, 0.0, 2.0)
    assert (s.x, s.y) == pytest.approx((0.0, 100.0), abs=1e-9)
    s = unicycle_step(UnicycleState(10, 20, 0.0), 0.0, math.pi / 2, 1.0)
    assert (s.x, s.y, s.theta) == pytest.approx((10.0, 20.0, math.pi / 2))


def test_unicycle_arc_matches_fine_euler_integration():
    exact = unicycle_step(UnicycleState(0, 0, 0.3), 40.0, 0.7, 1.0)
    s = UnicycleState(0, 0, 0.3)
    for _ in range(100_000):
        s = UnicycleState(
            s.x + 40.0 * math.cos(s.theta) * 1e-5,
            s.y + 40.0 * math.sin(s.theta) * 1e-5,
            s.theta + 0.7 * 1e-5,
        )
    assert (exact.x, exact.y) == pytest.approx((s.x, s.y), abs=1e-3)


def lyapunov(actual: UnicycleState, desired: UnicycleState) -> float:
    e_theta = math.atan2(
        math.sin(actual.theta - desired.theta), math.cos(actual.theta - desired.theta)
    )
    return 0.5 * ((actual.x - desired.x) ** 2 + (actual.y - desired.y) ** 2 + e_theta**2)


@settings(max_examples=300, deadline=None)
@given(
    ex=st.floats(-50, 50),
    ey=st.floats(-50, 50),
    eth=st.floats(-2.5, 2.5),
    theta_d=st.floats(-math.pi, math.pi),
    v_d=st.floats(0, 80),
    w_d=st.floats(-1.5, 1.5),
)
def test_lyapunov_function_never_increases(ex, ey, eth, theta_d, v_d, w_d):
    """V = (e_x^2 + e_y^2 + e_theta^2) / 2 decreases under eqs. 7-8 (Pozzani 2023)."""
    desired = UnicycleState(0.0, 0.0, theta_d)
    actual = UnicycleState(ex, ey, theta_d + eth)
    v, w = lyapunov_control(actual, desired, v_d, w_d, kp=2.0, ktheta=4.0)
    dt = 1e-6
    before = lyapunov(actual, desired)
    after = lyapunov(unicycle_step(actual, v, w, dt), unicycle_step(desired, v_d, w_d, dt))
    # dV/dt <= 0 up to integration error of order dt^2
    assert (after - before) / dt <= 1e-3 * (1 + before)


def drive(bot: Duckybot, seconds: float) -> list[float]:
    errors = []
    t = bot.time
    while t < seconds:
        t = round(t + 0.05, 9)
        bot.advance(t)
        errors.append(bot.tracking_error)
    return errors


def test_tracks_its_reference_with_bounded_error_and_parks():
    loaded = {"now": False}
    bot = Duckybot(
        "bot",
        (0.0, -300.0, math.pi / 2),
        [
            Leg("drive", (0.0, -150.0)),
            Leg("park", (150.0, 0.0), heading=0.0, until="loaded", wait=1.0),
            Leg("drive", (150.0, 250.0)),
        ],
        DuckybotParams(speed=50.0, noise=0.05),
        np.random.default_rng(4),
        loaded=lambda: loaded["now"],
    )
    errors = drive(bot, 20.0)
    assert bot.parked
    assert max(errors) < 15.0, "tracks its reference closely despite wheel noise"
    assert math.hypot(bot.state.x - 150.0, bot.state.y) < 4.0
    assert abs(math.remainder(bot.state.theta, 2 * math.pi)) < math.radians(4)
    parked_at = (bot.state.x, bot.state.y)
    drive(bot, 40.0)
    assert bot.parked and (bot.state.x, bot.state.y) == parked_at, "waits, motors off, until loaded"
    loaded["now"] = True
    drive(bot, 40.5)
    assert bot.parked, "leaves only after the wait"
    drive(bot, 50.0)
    assert bot.phase == "done"
    assert math.hypot(bot.state.x - 150.0, bot.state.y - 250.0) < 6.0


def test_converges_from_a_start_off_its_reference():
    bot = Duckybot(
        "bot",
        (0.0, 0.0, 0.0),
        [Leg("drive", (400.0, 0.0))],
        DuckybotParams(noise=0.0),
        np.random.default_rng(0),
    )
    bot.state = UnicycleState(0.0, 25.0, 0.4)
    errors = drive(bot, 6.0)
    assert errors[0] > 20.0 and errors[-1] < 1.0


def test_park_times_out_without_a_load():
    bot = Duckybot(
        "bot",
        (0.0, 0.0, 0.0),
        [Leg("park", (100.0, 0.0), timeout=5.0), Leg("drive", (100.0, 100.0))],
        DuckybotParams(noise=0.0),
        np.random.default_rng(0),
    )
    drive(bot, 6.0)
    assert bot.parked
    drive(bot, 8.0)
    assert bot.leg_index == 1 and not bot.parked, "left after 5 s parked, unloaded"
