"""DH arm on an SSC-32: driver against the board emulator over a real pseudo-terminal."""

from __future__ import annotations

import numpy as np
import pytest
import serial
from arm_fixtures import ArmSim, connected, served

from armtree.api.clock import WallClock
from armtree.api.rig import MotionStatus, RigContext
from armtree.errors import ConfigError, HardwareFault, Unreachable
from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.loader.profile import load_profile
from armtree.plugins.arms.dh import ssc32 as S
from armtree.plugins.arms.dh.plugin import dh_factory
from armtree.plugins.arms.vicra.plugin import vicra_factory


def puma_config(**extra):
    return {**load_profile("dh_puma560").component("arm"), "port": "sim", **extra}


class Sim(ArmSim):
    """A factory-built DH arm on ``port: sim`` stepped as the runtime does it."""

    dt = 0.02
    limit = 1000

    def __init__(self, config):
        super().__init__(dh_factory, config)

    def sent(self):
        return self.received_bytes()


@pytest.fixture
def sim():
    config = puma_config(gripper={"channel": 6, "table": [[500, 0], [2500, 90]]}, suction_channel=7)
    yield from connected(Sim(config))


@pytest.fixture
def ramp():
    """The arm moved by the board's own linear ramps (``trajectory: none``)."""
    yield from connected(Sim(puma_config(trajectory="none")))


def test_shipped_profiles_build_their_models():
    registry = get_plugin_manager().registry
    for name in ("dobot_magician", "vicra", "dh"):
        assert registry.has("arm", name)
    puma = dh_factory.model(load_profile("dh_puma560").component("arm"))
    motoman = dh_factory.model(load_profile("dh_motoman_l3").component("arm"))
    assert puma.dof == 6 and motoman.dof == 5
    np.testing.assert_allclose(puma.position(puma.home), [212.0, 149.0, 181.3], atol=0.1)
    np.testing.assert_allclose(motoman.position(motoman.home), [707.1, 0.0, 800.0], atol=0.1)
    # joint limits cut to what each fitted servo reaches
    assert puma.joints[2].lower > 0 and puma.joints[2].upper == 225.0


def test_connect_reads_the_version_and_pulses(sim):
    assert sim.arm.version == S.VERSION
    sim.tick(3)
    np.testing.assert_allclose(sim.arm.joints(), sim.arm.model.home, atol=1.0)


def test_without_a_trajectory_move_to_sends_one_timed_group_move_and_completes_on_q(ramp):
    sim = ramp
    target = np.array([300.0, 100.0, 150.0])
    handle = sim.arm.move_to(target)
    assert handle.status is MotionStatus.RUNNING
    sim.until(handle)
    assert handle.status is MotionStatus.DONE
    moves = [ln for ln in sim.sent().split(b"\r") if ln.startswith(b"#")]
    assert len(moves) == 1 and b"T" in moves[0]
    req = S.parse_request(moves[0].decode())
    assert sorted(req.moves) == [0, 1, 2, 3, 4, 5]
    # pulses are whole microseconds: the tool lands within a millimetre of the target
    np.testing.assert_allclose(sim.arm.model.position(sim.emu.true_joints()), target, atol=1.0)
    # the read-back (10 us steps) confirms the commanded pulses, which the driver then reports
    np.testing.assert_allclose(sim.arm.joints(), sim.emu.true_joints(), atol=1e-9)
    sim.arm.stop()
    sim.tick(2)
    step = max(abs(m.slope) for m in sim.arm.servos) * 10
    assert np.abs(sim.arm.joints() - sim.emu.true_joints()).max() <= step / 2 + 1e-9


def test_group_move_takes_the_time_the_slowest_joint_needs(ramp):
    sim = ramp
    goal = sim.arm.model.home + np.array([40.0, 0, 0, 0, 0, 0])
    handle = sim.arm.move_joints(goal, speed=0.5)
    t0 = sim.clock.now()
    sim.until(handle)
    elapsed = sim.clock.now() - t0
    assert elapsed >= 40.0 / (90.0 * 0.5) - 0.02


def test_stop_freezes_the_servos(sim):
    handle = sim.arm.move_joints(sim.arm.model.home + np.array([60.0, 0, 0, 0, 0, 0]), speed=0.2)
    sim.tick(10)
    sim.arm.stop()
    assert handle.status is MotionStatus.STOPPED
    sim.tick()
    frozen = sim.emu.true_joints()
    sim.tick(30)
    np.testing.assert_allclose(sim.emu.true_joints(), frozen, atol=1e-9)
    assert sim.arm.model.home[0] < frozen[0] < sim.arm.model.home[0] + 60.0
    assert b"STOP0 STOP1 STOP2 STOP3 STOP4 STOP5" in sim.sent()


def test_pump_and_gripper_channels(sim):
    assert sim.until(sim.arm.set_suction(True)).status is MotionStatus.DONE
    sim.tick()
    assert sim.emu.tool().suction and b"#7H\r" in sim.sent()
    sim.until(sim.arm.set_gripper(45.0))
    assert sim.emu.tool().gripper == pytest.approx(45.0, abs=0.1)


def test_no_pump_is_a_clear_failure():
    with Sim(puma_config()) as s:
        s.arm.connect()
        handle = s.arm.set_suction(True)
        assert handle.status is MotionStatus.FAILED and "no suction" in str(handle.error)


@pytest.mark.parametrize(
    ("target", "match"),
    [
        ([0.0, 0.0, 10.0, 0.0, 0.0, 0.0], "q3"),
        ([0.0, -45.0, 60.0, 0.0, -15.0, np.inf], "not finite"),
        ([0.0, -45.0, 60.0], "6 joints"),
    ],
)
def test_bad_targets_are_refused_and_nothing_is_sent(sim, target, match):
    before = sim.sent().count(b"#")
    handle = sim.arm.move_joints(target)
    assert handle.status is MotionStatus.FAILED
    assert isinstance(handle.error, Unreachable) and match in str(handle.error)
    sim.tick(2)
    assert sim.sent().count(b"#") == before
    assert sim.arm.move_to([5000.0, 0.0, 0.0]).status is MotionStatus.FAILED


def test_board_protocol_byte_exact():
    with Sim(puma_config()) as s:
        s.arm.connect()
        s.arm.close()
        with serial.Serial(s.arm.device, 115200, timeout=0.05) as port:
            start = float(s.emu.pulses(s.clock.now())[0])
            port.write(b"VER\r#0P1000T500\rQ QP0\r")
            s.tick()
            # the query is answered as it arrives, when the ramp has just begun
            assert port.read(64) == b"SSC32-V2.50USB\r+" + bytes([int(round(start / 10))])
            s.tick(30)
            port.write(b"Q QP0\r")
            s.tick()
            assert port.read(8) == b"." + bytes([100])


def test_link_cut_fails_the_move_and_interrupts(sim):
    handle = sim.arm.move_joints(sim.arm.model.home + np.array([60.0, 0, 0, 0, 0, 0]), speed=0.1)
    sim.tick(3)
    sim.emu.inject("cut")
    assert handle.wait(3.0)
    assert handle.status is MotionStatus.FAILED and isinstance(handle.error, HardwareFault)
    assert sim.interrupts


def test_a_marlin_board_is_recognised_as_the_wrong_protocol():
    with served(vicra_factory) as path:
        arm = dh_factory({**puma_config(), "port": path}, RigContext(None, WallClock()))
        arm.connect_timeout = 1.0
        with pytest.raises(HardwareFault, match="wrong protocol.*Marlin"):
            arm.connect()


def test_bad_servo_config_is_a_config_error():
    config = puma_config(servos=[{"channel": 0, "table": [[500, 500], [2500, 600]]}] * 6)
    with pytest.raises(ConfigError):
        dh_factory.model(config)


def test_two_runs_exchange_identical_bytes():
    def run():
        with Sim(puma_config()) as s:
            s.arm.connect()
            s.until(s.arm.move_to([300.0, 100.0, 150.0]))
            s.until(s.arm.move_joints(s.arm.model.home))
            return list(s.emu.transcript)

    assert run() == run()


def test_busy_port_is_a_clear_hardware_fault():
    with served(dh_factory, puma_config()) as path, serial.Serial(path, 115200, exclusive=True):
        arm = dh_factory({**puma_config(), "port": path}, RigContext(None, WallClock()))
        with pytest.raises(HardwareFault, match="busy") as err:
            arm.connect()
        assert err.value.device == path
