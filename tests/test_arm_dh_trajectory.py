"""A DH arm on an SSC-32 is driven along timed trajectories (Pozzani 2023, eq. 2), validated first.

The board only ramps each servo linearly to a set point, so the driver streams
the trajectory as short group moves. These tests run sim_dh's five-axis arm
against the board emulator over a real pseudo-terminal and read where the
servos really are (the emulator's true joints).
"""

from __future__ import annotations

import numpy as np
import pytest
from arm_fixtures import ArmSim, connected

from armtree.api.rig import MotionStatus
from armtree.errors import PlanningError
from armtree.loader.profile import load_profile
from armtree.plugins.arms.dh import ssc32 as S
from armtree.plugins.arms.dh.plugin import dh_factory

#: A post in front of the arm: sweeping out to [300, 0, 30] passes through it.
POST = {"obstacles": [{"box": {"center": [240, 0, 50], "size": [40, 40, 100]}}], "table": {"z": 0}}


def dh_config(**extra):
    return {**load_profile("sim_dh").component("arm"), "port": "sim", **extra}


class Sim(ArmSim):
    """sim_dh's arm, ticked every 10 ms so the true motion is sampled finely."""

    dt = 0.01
    limit = 1000

    def __init__(self, config, profile=None):
        super().__init__(dh_factory, config, profile)

    def moves(self) -> list[bytes]:
        return [ln for ln in self.received_bytes().split(b"\r") if ln.startswith(b"#")]


def follow(sim, handle):
    """Tick until ``handle`` is done; the run-clock times and true joints at every tick."""
    times, joints = [sim.clock.now()], [sim.emu.true_joints()]
    while not handle.done:
        sim.tick()
        times.append(sim.clock.now())
        joints.append(sim.emu.true_joints())
        assert len(times) < sim.limit, "the motion did not finish"
    return np.array(times), np.array(joints)


@pytest.fixture
def sim():
    yield from connected(Sim(dh_config()))


@pytest.mark.parametrize("kind", ["cubic", "quintic"])
def test_the_servos_follow_the_trajectory_within_the_joint_limits(kind):
    with Sim(dh_config(trajectory=kind)) as sim:
        sim.arm.connect()
        check_following(sim)


def check_following(sim):
    model = sim.arm.model
    goal = model.ik(np.array([220.0, -150.0, 40.0]), near=model.home)
    handle = sim.arm.move_joints(goal)
    t0, trajectory = sim.arm.last_trajectory
    times, true = follow(sim, handle)
    assert handle.status is MotionStatus.DONE
    assert trajectory.duration > 0.5
    # one set point per stream period, not one jump to the goal
    assert len(sim.moves()) >= trajectory.duration / sim.arm.stream_period - 1
    # where the servos are against where the trajectory says, at every 10 ms; it starts
    # from the read-back (10 us steps, 0.45 degree at most off), gone after one set point
    planned = trajectory.position(times - t0)
    start_error = np.abs(true[0] - planned[0])
    assert start_error.max() <= 5 * 0.091  # half a read-back step of 10 us
    fading = np.clip(1.0 - (times - t0) / sim.arm.stream_period, 0.0, 1.0)[:, None]
    assert np.all(np.abs(true - planned) <= 0.3 + start_error * fading)
    np.testing.assert_allclose(true[-1], goal, atol=0.1)
    assert np.all(model.within_limits(true))
    # speeds within each joint's limit (whole-microsecond pulses add at most 1.8 deg/s)
    vmax = np.array([j.max_speed for j in model.joints])
    amax = np.array([j.max_accel for j in model.joints])
    velocity = np.diff(true, axis=0) / np.diff(times)[:, None]
    assert np.all(np.abs(velocity) <= vmax + 1.8)
    # and the speed changes from one stream period to the next within the acceleration limit
    step = int(round(sim.arm.stream_period / sim.dt))
    accel = np.diff(velocity[::step], axis=0) / sim.arm.stream_period
    assert np.all(np.abs(accel) <= amax + 2 * 1.8 / sim.arm.stream_period)
    assert np.abs(velocity).max() > 0.5 * vmax.min(), "it moved at speed, not crept"


def test_a_path_passes_its_via_points_without_stopping(sim):
    model = sim.arm.model
    points = [model.ik(np.array(p), near=model.home) for p in ([200, 100, 80], [220, -120, 60])]
    handle = sim.arm.follow_path(np.stack(points))
    t0, trajectory = sim.arm.last_trajectory
    times, true = follow(sim, handle)
    assert handle.status is MotionStatus.DONE
    np.testing.assert_allclose(true[-1], points[-1], atol=0.1)
    via = trajectory.times[1]
    near_via = np.abs(times - t0 - via) < 0.03
    speed = np.abs(np.diff(true, axis=0) / sim.dt).max(axis=1)
    assert speed[near_via[1:]].min() > 5.0, "the arm went through the via point moving"


def test_a_trajectory_through_an_obstacle_is_refused_before_a_byte_is_sent():
    with Sim(dh_config(), profile=POST) as sim:
        sim.arm.connect()
        sim.tick(3)
        model = sim.arm.model
        goal = model.ik(np.array([300.0, 0.0, 30.0]), near=model.home)
        # both ends are free: only the way between them is not
        assert sim.arm.checker.valid(model.home) and sim.arm.checker.valid(goal)
        before = len(sim.moves())
        handle = sim.arm.move_joints(goal)
        assert handle.status is MotionStatus.FAILED
        assert isinstance(handle.error, PlanningError) and handle.error.reason == "collision"
        assert "box0" in str(handle.error)
        sim.tick(20)
        assert len(sim.moves()) == before
        np.testing.assert_allclose(sim.emu.true_joints(), model.home, atol=0.1)
        # a goal the arm reaches around the post is followed
        free = model.ik(np.array([150.0, -150.0, 40.0]), near=model.home)
        assert follow(sim, sim.arm.move_joints(free))[1][-1] == pytest.approx(free, abs=0.1)


def test_a_target_outside_a_servo_range_is_refused_before_a_byte_is_sent(sim):
    before = len(sim.moves())
    beyond = sim.arm.model.home.copy()
    beyond[0] = 95.0  # the base servo turns -80.7..80.6 over 600..2400 us; the limit is 89.8
    handle = sim.arm.follow_path(np.stack([sim.arm.model.home, beyond]))
    assert handle.status is MotionStatus.FAILED and "q1" in str(handle.error)
    sim.tick(5)
    assert len(sim.moves()) == before


def test_stopping_a_stream_holds_the_servos_and_sends_no_more_set_points(sim):
    model = sim.arm.model
    handle = sim.arm.move_joints(model.ik(np.array([220.0, -150.0, 40.0]), near=model.home))
    sim.tick(20)
    sim.arm.stop()
    assert handle.status is MotionStatus.STOPPED
    sim.tick()
    sent = len(sim.moves())
    frozen = sim.emu.true_joints()
    sim.tick(30)
    assert len(sim.moves()) == sent
    np.testing.assert_allclose(sim.emu.true_joints(), frozen)
    assert b"STOP0 STOP1 STOP2 STOP3 STOP4" in sim.received_bytes()


def test_streamed_set_points_are_whole_pulses_in_the_board_range(sim):
    model = sim.arm.model
    sim.until(sim.arm.move_joints(model.ik(np.array([150.0, 150.0, 40.0]), near=model.home)))
    for line in sim.moves():
        request = S.parse_request(line.decode())
        assert request.errors == 0 and request.time_ms is not None
        assert all(S.PULSE_MIN <= p <= S.PULSE_MAX for p, _ in request.moves.values())


def test_a_servo_slip_lasts_until_the_servo_is_next_commanded(sim):
    # hobby servos hold position in their own loop: a slip does not pile up like lost steps
    model = sim.arm.model
    sim.tick(2)
    sim.emu.inject("missed_steps", joint=1, amount=2.0)
    sim.tick(5)
    assert sim.emu.true_joints()[1] - model.home[1] == pytest.approx(2.0, abs=1e-6)
    goal = model.ik(np.array([220.0, -150.0, 40.0]), near=model.home)
    times, true = follow(sim, sim.arm.move_joints(goal))
    np.testing.assert_allclose(true[-1], goal, atol=0.1)
    assert np.abs(np.diff(true[:, 1])).max() < 2.0, "it moved from where it was, no jump"


def test_a_stream_sent_late_aims_as_far_ahead_as_it_was_behind():
    from armtree.maths.motion.trajectory import plan_trajectory
    from armtree.plugins.arms.common.streaming import MIN_RAMP_S, TrajectoryStream

    trajectory = plan_trajectory(np.array([[0.0], [90.0]]), durations=[1.0])
    stream = TrajectoryStream(trajectory, t0=10.0, period=0.05)
    first = stream.next(10.0)
    assert first.ramp_s == pytest.approx(0.05) and not first.last
    np.testing.assert_allclose(first.q, trajectory.position(0.05))
    assert not stream.due(10.04) and stream.due(10.05)
    late = stream.next(10.2)  # called 0.2 s after the last set point, 0.15 s late
    assert late.ramp_s == pytest.approx(0.2)
    np.testing.assert_allclose(late.q, trajectory.position(0.4))
    last = stream.next(11.2)  # past the end: the goal, at once
    assert last.last and last.ramp_s == MIN_RAMP_S
    np.testing.assert_allclose(last.q, [90.0])
    assert not stream.due(12.0)
    with pytest.raises(StopIteration):
        stream.next(12.0)
