"""Drivers that doubt what they read: implausible readings are corrupt, noise is no link."""

from __future__ import annotations

import os
import pty
import threading
import time

import numpy as np
import pytest
from arm_fixtures import ArmSim, connected
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from armtree.api.clock import VirtualClock, WallClock
from armtree.errors import HardwareFault
from armtree.plugins.arms.common.plausibility import (
    LIMIT_MARGIN,
    RESYNC_S,
    STABLE_FRAMES,
    StatusGuard,
)
from armtree.plugins.arms.dobot_v1 import codec
from armtree.plugins.arms.dobot_v1.driver import DobotV1Driver
from armtree.plugins.arms.dobot_v1.kinematics import DobotV1Model
from armtree.plugins.arms.dobot_v1.plugin import dobot_v1_factory
from armtree.plugins.arms.vicra.plugin import vicra_factory

MODEL = DobotV1Model()


def plausible(q: np.ndarray, model=MODEL) -> bool:
    q = np.asarray(q, dtype=float)
    lower = np.asarray(model.lower) - LIMIT_MARGIN - 1e-9
    upper = np.asarray(model.upper) + LIMIT_MARGIN + 1e-9
    return bool(np.all(np.isfinite(q)) and np.all(q >= lower) and np.all(q <= upper))


# -- the guard -------------------------------------------------------------------------


def test_the_guard_refuses_non_finite_out_of_limits_and_too_fast_readings() -> None:
    guard = StatusGuard(MODEL)
    home = np.asarray(MODEL.home, dtype=float)
    assert guard.check(home, 0.0) is None
    assert "not a finite number" in guard.check([np.nan, 10.0, 50.0], 0.05)
    assert "outside its limits" in guard.check([1.7e37, 10.0, 50.0], 0.05)
    assert "jumped" in guard.check(home + [40.0, 0.0, 0.0], 0.05)  # 800 deg/s
    assert guard.check(home + [4.0, 0.0, 0.0], 0.05) is None  # 80 deg/s: the base can
    assert (guard.believed, guard.corrupt) == (2, 3)


def test_after_a_pause_the_guard_reads_the_arm_again_instead_of_losing_the_link() -> None:
    # Issue 32: SIGSTOP for 3 s under --realtime; frames sent before the pause arrive with
    # frames from after it, and every one was refused as a jump "in 0 s".
    guard = StatusGuard(MODEL, frame_bytes=42)
    home = np.asarray(MODEL.home, dtype=float)
    moved = home + [30.0, 0.0, 0.0]  # where the arm went on to while the process was stopped
    for i in range(STABLE_FRAMES):
        guard.check(home, 0.05 * i)
    # Read after the pause, so stamped with its end: a stale frame, then a fresh one.
    assert guard.check(home, 3.2) is None
    assert "jumped" in guard.check(moved, 3.2)  # without the resync: refused, "in 0 s"
    guard.resync(3.2)
    assert not guard.stable
    assert guard.check(home, 3.2) is None  # a stale frame from before the pause
    assert guard.check(moved, 3.2) is None  # the arm where it is now
    for i in range(STABLE_FRAMES):
        assert guard.check(moved, 3.21 + 0.01 * i) is None
    assert guard.stable and guard.verdict() is None
    # Once the resync is over, jumps are judged again against the new reference.
    after = 3.2 + RESYNC_S
    assert guard.check(moved, after) is None
    assert "jumped" in guard.check(home, after + 0.01)


def test_the_guard_loses_a_link_whose_frames_are_mostly_corrupt() -> None:
    guard = StatusGuard(MODEL, frame_bytes=42)
    home = np.asarray(MODEL.home, dtype=float)
    for i in range(STABLE_FRAMES):
        guard.check(home, 0.05 * i)
    assert guard.stable and guard.verdict() is None
    guard.skipped(42 * 30)  # 30 frames' worth of bytes that were not frames
    assert "30 of the last" in guard.verdict()
    assert not guard.stable


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.lists(st.floats(width=32), min_size=3, max_size=3),
            st.floats(min_value=0.0, max_value=0.2),
        ),
        max_size=40,
    )
)
def test_property_a_believed_reading_is_plausible_and_follows_the_last(readings) -> None:
    guard = StatusGuard(MODEL)
    t, last, last_t = 0.0, None, None
    for q, dt in readings:
        t += dt
        if guard.check(q, t) is None:
            assert plausible(q)
            if last is not None:
                allowed = np.array([j.max_speed for j in MODEL.joints]) * 2.0 * (t - last_t) + 2.0
                assert np.all(np.abs(np.asarray(q) - last) <= allowed + 1e-6)
            last, last_t = np.asarray(q, dtype=float), t


# -- Dobot V1.0 (no checksum) ------------------------------------------------------------


def v1_driver() -> DobotV1Driver:
    """A driver fed by hand: no port is opened."""
    return DobotV1Driver(MODEL, "/dev/null-hostile", baud=9600, clock=VirtualClock())


def status_frame(joints, is_grab=0.0, gripper=0.0) -> bytes:
    x, y, z = MODEL.position(np.asarray(joints, dtype=float)).tolist()
    return codec.Status(x, y, z, 0.0, *joints, 0.0, is_grab, gripper).encode()


chunks = st.one_of(
    st.binary(max_size=60),
    st.builds(
        lambda q, grab, grip: codec.encode_frame([0, 0, 0, 0, *q, 0, grab, grip]),
        st.lists(st.floats(width=32), min_size=3, max_size=3),
        st.sampled_from([0.0, 1.0, 0.5]),
        st.floats(width=32),
    ),
)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(chunks, max_size=30))
def test_property_v1_any_byte_stream_gives_plausible_frames_or_counted_corruption(data) -> None:
    driver = v1_driver()
    for i, chunk in enumerate(data):
        driver._now = 0.05 * i
        driver.on_data(chunk)
        status = driver._status
        if status is not None:
            assert plausible(status.joints)
    assert driver.frames_received == driver.guard.believed


def test_v1_frames_with_huge_or_nan_joints_are_not_believed() -> None:
    driver = v1_driver()
    home = list(MODEL.home)
    for i in range(STABLE_FRAMES):
        driver._now = 0.05 * i
        driver.on_data(status_frame(home))
    assert driver.guard.stable
    for bad in ([1.7e37, 10.0, 50.0], [0.0, float("nan"), 50.0], [1.9e20, 1.9e20, 1.9e20]):
        driver.on_data(codec.encode_frame([0, 0, 0, 0, *bad, 0, 0, 0]))
        assert np.allclose(driver._status.joints, home)
    assert driver.guard.corrupt == 3


class V1Sim(ArmSim):
    def __init__(self, **config):
        super().__init__(dobot_v1_factory, {"port": "sim", **config})


@pytest.mark.parametrize(("rate", "within_s"), [(0.05, 4.0), (1.0, 1.5)])
def test_v1_a_corrupted_link_is_lost_and_nothing_implausible_is_believed(rate, within_s) -> None:
    with V1Sim() as sim:
        sim.arm.connect()
        sim.tick(5)
        sim.emu.inject("corrupt", rate=rate)

        def believed_is_plausible() -> None:
            status = sim.arm._status
            assert status is None or plausible(status.joints)

        ticks = ticks_until_interrupted(sim, 80, believed_is_plausible)
        fault = sim.interrupts[0][1]
        assert isinstance(fault, HardwareFault) and "link lost" in str(fault)
        # noise: no plausible frame within the 1 s link timeout; 5 % of bytes flipped:
        # most frames corrupt within a window of 40 frames (2 s at 20 Hz)
        assert ticks * sim.dt <= within_s


def test_v1_random_bytes_do_not_connect() -> None:
    master, slave = pty.openpty()
    stop = threading.Event()

    def noise() -> None:
        rng = np.random.default_rng(7)
        while not stop.is_set():
            os.write(master, rng.integers(0, 256, 400, dtype=np.uint8).tobytes())
            time.sleep(0.005)

    feeder = threading.Thread(target=noise, daemon=True)
    feeder.start()
    driver = DobotV1Driver(
        MODEL, os.ttyname(slave), baud=9600, clock=WallClock(), connect_timeout=0.8
    )
    try:
        with pytest.raises(HardwareFault, match="wrong protocol|no answer"):
            driver.connect()
        assert not driver.connected
        assert driver.guard.believed == 0
    finally:
        stop.set()
        feeder.join(2)
        driver.close()
        os.close(master)
        os.close(slave)


# -- VICRA (Marlin lines) ----------------------------------------------------------------


class VicraSim(ArmSim):
    dt = 0.1

    def __init__(self, **config):
        super().__init__(vicra_factory, {"port": "sim", **config})


def test_vicra_noise_with_ok_lines_does_not_keep_a_dead_link_alive() -> None:
    with VicraSim() as sim:
        connection = connected(sim)
        next(connection)
        sim.tick(5)
        sim.emu.inject("cut", silent=1)  # the board says nothing more...
        fd = sim.emu._master

        def noise() -> None:  # ...but the line carries noise full of "ok"
            os.write(fd, b"ok\nok T:20\necho:busy: processing\nok\n")
            time.sleep(0.01)  # cut from the barrier: let the driver's thread read it

        ticks = ticks_until_interrupted(sim, 200, noise)
        fault = sim.interrupts[0][1]
        assert isinstance(fault, HardwareFault) and "link lost" in str(fault)
        assert ticks * sim.dt <= sim.arm.link_timeout + 1.0


def ticks_until_interrupted(sim: ArmSim, limit: int, before_tick=lambda: None) -> int:
    """Ticks until the driver interrupted the run (AssertionError after ``limit``)."""
    for ticks in range(1, limit + 1):
        before_tick()
        sim.tick()
        if sim.interrupts:
            return ticks
    raise AssertionError(f"no interrupt within {limit} ticks")
