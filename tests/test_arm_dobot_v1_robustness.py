"""Dobot V1: fuzzed bytes never break an emulator or a driver; wrong devices; faults; plugin."""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.api.clock import VirtualClock, WallClock
from armtree.api.emulation import SHARED_KEY
from armtree.api.rig import MotionStatus, RigContext
from armtree.errors import ConfigError, HardwareFault
from armtree.plugins.arms.dobot_v1 import codec
from armtree.plugins.arms.dobot_v1 import opendobot as od
from armtree.plugins.arms.dobot_v1.driver import DobotV1Driver
from armtree.plugins.arms.dobot_v1.emulator import DobotV1Emulator
from armtree.plugins.arms.dobot_v1.kinematics import DobotV1Model
from armtree.plugins.arms.dobot_v1.opendobot_driver import OpenDobotDriver
from armtree.plugins.arms.dobot_v1.opendobot_emulator import OpenDobotEmulator
from armtree.plugins.arms.dobot_v1.plugin import armtree_arms, dobot_v1_factory

MODEL = DobotV1Model()

frames = st.lists(
    st.floats(width=32, allow_nan=True, allow_infinity=True), min_size=10, max_size=10
)
chunks = st.lists(
    st.one_of(st.binary(max_size=60), frames.map(lambda v: codec.encode_frame(v))), max_size=12
)


@settings(max_examples=60, deadline=None)
@given(chunks)
def test_original_emulator_survives_any_bytes(data):
    emu = DobotV1Emulator(MODEL, VirtualClock())
    sent = []
    emu.send = sent.append
    t = 0.0
    for chunk in data:
        emu.on_bytes(chunk, t)
        t += 0.05
        emu.on_timer(t)
    assert np.all(np.isfinite(emu.true_joints()))
    assert np.all(emu.true_joints() >= [-135, -5, -10]) and np.all(
        emu.true_joints() <= [135, 85, 95]
    )


@settings(max_examples=60, deadline=None)
@given(st.lists(st.binary(max_size=30), max_size=12))
def test_open_dobot_emulator_survives_any_bytes(data):
    emu = OpenDobotEmulator(MODEL, VirtualClock())
    emu.send = lambda b: None
    emu.on_start()
    t = 0.0
    for chunk in data:
        emu.on_bytes(chunk, t)
        t += 0.05
        emu.on_timer(t)
        assert len(emu._rx) < 24
    assert np.all(np.isfinite(emu.true_joints()))


@settings(max_examples=60, deadline=None)
@given(chunks)
def test_original_driver_survives_any_bytes(data):
    drv = DobotV1Driver(MODEL, "/dev/null-armtree", baud=9600, clock=VirtualClock())
    for chunk in data:
        drv.on_data(chunk)
        assert drv._parser.buffered < 42


@settings(max_examples=60, deadline=None)
@given(st.lists(st.binary(max_size=30), max_size=12))
def test_open_dobot_driver_survives_any_bytes(data):
    drv = OpenDobotDriver(MODEL, "/dev/null-armtree", baud=115200, clock=VirtualClock())
    drv._inflight = None
    drv._queue_request = lambda req, first=False: None
    for cmd in (od.GET_COUNTERS, od.STEPS, od.BOARD_VERSION):
        from armtree.plugins.arms.dobot_v1.opendobot_driver import _Request

        req = _Request(cmd)
        req.frame, req.crc = od.request(cmd, bytes(od.REQUEST_LEN[cmd]))
        drv._inflight = req
        for chunk in data:
            drv.on_data(chunk)
            assert len(drv._rx) <= 14


def test_marlin_banner_where_a_dobot_was_expected():
    master, slave = os.openpty()
    path = os.ttyname(slave)

    class Booting(DobotV1Driver):
        def on_open(self):
            super().on_open()
            os.write(master, b"start\necho: External Reset\nMarlin 1.1.9\n")

    drv = Booting(MODEL, path, baud=9600, clock=WallClock(), connect_timeout=0.3)
    try:
        with pytest.raises(HardwareFault, match="wrong protocol.*Marlin") as err:
            drv.connect()
        assert err.value.device == path
    finally:
        os.close(master)
        os.close(slave)


def test_missed_steps_move_the_true_pose_only():
    clock = VirtualClock()
    context = RigContext(profile=None, clock=clock)
    arm = dobot_v1_factory({"port": "sim"}, context)
    emu = context.shared[SHARED_KEY]
    try:
        arm.connect()
        emu.inject("missed_steps", joint=0, amount=-3.0)
        handle = arm.move_joints([20.0, 5.0, 45.0])
        for _ in range(100):
            if handle.done:
                break
            for step in context.steppers:
                step(clock.advance(0.05))
        assert handle.status is MotionStatus.DONE
        assert arm.joints()[0] == pytest.approx(20.0, abs=1e-4)
        assert emu.true_joints()[0] == pytest.approx(17.0, abs=1e-4)
    finally:
        arm.close()
        for closer in reversed(context.closers):
            closer()


def test_plugin_registers_dobot_v1_with_model_and_emulator():
    factory = armtree_arms()["dobot_v1"]
    assert factory is dobot_v1_factory
    model = factory.model({"tool_offset_mm": 50.9})
    assert isinstance(model, DobotV1Model) and model.d == 50.9
    emu = factory.emulator({"firmware": "open-dobot", "board": "ramps"}, VirtualClock())
    assert isinstance(emu, OpenDobotEmulator) and emu.board is od.RAMPS
    names = {p.name for p in factory.PARAMS}
    assert {"port", "firmware", "baud", "tool_offset_mm"} <= names
    with pytest.raises(ConfigError, match="firmware"):
        factory({"firmware": "marlin"}, RigContext(None, VirtualClock()))


def test_profile_validation_rejects_an_unknown_firmware(tmp_path):
    from armtree.loader.profile import load_profile

    bad = tmp_path / "bad.yaml"
    bad.write_text("profile: bad\narm: {type: dobot_v1, port: sim, firmware: marlin}\n")
    with pytest.raises(ConfigError) as err:
        load_profile(str(bad))
    assert "firmware" in str(err.value)
    good = tmp_path / "good.yaml"
    good.write_text("profile: good\narm: {type: dobot_v1, port: sim, firmware: open-dobot}\n")
    assert load_profile(str(good)).component("arm")["firmware"] == "open-dobot"
