"""The bus-servo arm driver against its emulator over a real pty, stepped as the runtime does.

Connecting pings every configured id (a missing or wrong servo is a fault naming it),
writes the calibration's homing offsets, turns torque on; a motion goes out as sync
writes of goals and comes back as sync reads of positions; a lost status packet is
asked for again and counted, within a budget; an overloaded servo stops the arm with
its torque off; torque goes off when the driver closes.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from arm_fixtures import ArmSim

import armtree
from armtree.api.rig import MotionStatus
from armtree.errors import HardwareFault
from armtree.plugins.arms.bus_servo import bus
from armtree.plugins.arms.bus_servo.bus import PacketReader
from armtree.plugins.arms.bus_servo.plugin import koch_factory, so101_factory
from armtree.plugins.arms.bus_servo.servo import SimServo
from armtree.plugins.arms.bus_servo.tables import MODELS

FACTORIES = {"so101": so101_factory, "koch": koch_factory}


class Sim(ArmSim):
    dt = 0.05
    limit = 200

    def __init__(self, arm: str, **extra):
        config = {**armtree.load_profile(f"sim_{arm}").component("arm"), **extra}
        super().__init__(FACTORIES[arm], config)

    def packets(self) -> list[bus.Packet]:
        """Every instruction packet the driver sent, in order."""
        return PacketReader(self.arm.codec, status=False).feed(self.received_bytes())

    def torque(self) -> dict[int, bool]:
        return {i: s.torque for i, s in self.emu.servos.items()}


@pytest.fixture(params=["so101", "koch"])
def arm(request):
    with Sim(request.param) as sim:
        yield sim


def connected(sim: Sim) -> Sim:
    sim.arm.connect()
    sim.tick(2)
    return sim


def test_connecting_pings_every_id_then_holds_the_arm_with_torque_on(arm):
    connected(arm)
    sent = arm.packets()
    pings = [p.id for p in sent if p.instruction == bus.PING]
    assert pings == [1, 2, 3, 4, 5, 6]
    assert all(arm.torque().values())
    # the joints read back where the emulated arm stands, through the calibration
    np.testing.assert_allclose(arm.arm.joints(), arm.emu.true_joints(), atol=0.1)
    np.testing.assert_allclose(arm.arm.joints(), arm.arm.model.home, atol=0.1)
    assert arm.arm.tool.gripper == pytest.approx(45.0, abs=0.1)  # the gripper stands open


def test_a_missing_servo_is_a_fault_naming_its_id(arm):
    del arm.emu.servos[3]
    with pytest.raises(HardwareFault) as caught:
        arm.arm.connect()
    message = str(caught.value)
    assert "servo 3 (elbow_flex) did not answer a ping in " in message
    assert arm.emu.path in message and "baud rate (1,000,000)" in message


def test_a_servo_of_another_model_is_a_fault_naming_it():
    with Sim("koch") as sim:
        old = sim.emu.servos[4]
        sim.emu.servos[4] = SimServo(MODELS["xl430-w250"], 4, old.actual(0.0))
        with pytest.raises(
            HardwareFault,
            match=r"servo 4 \(wrist_flex\) is a xl430-w250 \(1060\), expected a xl330-m288 \(1200\)",
        ):
            sim.arm.connect()
    with Sim("so101") as sim:
        other = dataclasses.replace(MODELS["sts3215"], number=1284, name="sts3250")
        sim.emu.servos[2] = SimServo(other, 2, sim.emu.servos[2].actual(0.0))
        with pytest.raises(HardwareFault, match=r"servo 2 \(shoulder_lift\) is a model 1284"):
            sim.arm.connect()


def test_goals_go_out_as_sync_writes_and_positions_come_back_as_sync_reads(arm):
    connected(arm)
    before = len(arm.packets())
    target = np.array([120.0, -60.0, 45.0])
    handle = arm.until(arm.arm.move_to(target))
    assert handle.status is MotionStatus.DONE
    np.testing.assert_allclose(arm.arm.model.position(arm.emu.true_joints()), target, atol=1.0)
    during = arm.packets()[before:]
    writes = [p for p in during if p.instruction == bus.SYNC_WRITE]
    reads = [p for p in during if p.instruction == bus.SYNC_READ]
    assert len(writes) >= 5 and len(reads) >= len(writes)
    codec = arm.arm.codec
    address, goals = codec.sync_write_items(writes[-1].params)
    assert address == arm.arm._goal_span[0] and sorted(goals) == [1, 2, 3, 4, 5]
    assert codec.sync_read_ids(reads[-1].params)[2] == [1, 2, 3, 4, 5, 6]
    assert not any(p.instruction in (bus.READ, bus.WRITE) for p in during)  # all in sync


def test_a_lost_status_packet_is_asked_for_again_and_counted(arm):
    connected(arm)
    arm.emu.inject("lost_replies", count=2)
    before = len(arm.packets())
    arm.tick(6)
    assert arm.arm.lost_status == 2 and arm.arm.fault is None and not arm.interrupts
    again = [p for p in arm.packets()[before:] if p.instruction == bus.SYNC_READ]
    # the second ask goes to the servos that were silent only
    assert [arm.arm.codec.sync_read_ids(p.params)[2] for p in again[:2]] == [
        [1, 2, 3, 4, 5, 6],
        [1, 2],
    ]
    handle = arm.until(arm.arm.move_joints(arm.arm.model.home + [10, 0, 0, 0, 0]))
    assert handle.status is MotionStatus.DONE


def test_past_the_retry_budget_the_link_is_lost_naming_the_servo(arm):
    connected(arm)
    handle = arm.arm.move_joints(arm.arm.model.home + [20, 0, 0, 0, 0])
    del arm.emu.servos[2]  # unplugged
    arm.tick(10)
    assert not handle.done  # asked again, until a second of silence (link_timeout)
    arm.tick(15)
    assert handle.status is MotionStatus.FAILED
    (reason, fault), *_ = arm.interrupts
    assert reason == f"link lost on {arm.emu.path}" and fault.device == arm.emu.path
    assert (
        "servo 2 (shoulder_lift) did not answer the read of its present position in 20 asks "
        "over 1.00 s (20 status packets lost in all)"
    ) in fault.message


def test_an_overloaded_servo_stops_the_arm_with_every_torque_off(arm):
    connected(arm)
    handle = arm.arm.move_joints(arm.arm.model.home + [30, 0, 0, 0, 0])
    arm.tick(3)
    arm.emu.inject("overload", joint=1)
    arm.tick(4)
    assert handle.status is MotionStatus.FAILED
    (reason, fault), *_ = arm.interrupts
    assert reason == "servo 2 (shoulder_lift): overload"
    assert (
        "servo 2 (shoulder_lift) reports overload: the arm is stopped and its torque off"
        in fault.message
    )
    assert not any(arm.torque().values())


def test_closing_turns_every_torque_off(arm):
    connected(arm)
    assert all(arm.torque().values())
    arm.arm.close()
    arm.tick()
    assert not any(arm.torque().values())


def test_a_servo_holding_another_homing_offset_gets_the_calibrations(arm):
    servo = arm.emu.servos[3]
    wanted = servo.get("homing_offset")
    reg = servo.model.register("homing_offset")
    servo.write(reg.address, bytes(reg.size), 0.0)  # calibrated since by another program
    assert servo.get("homing_offset") == 0 != wanted
    connected(arm)
    assert servo.get("homing_offset") == wanted
    np.testing.assert_allclose(arm.arm.joints(), arm.emu.true_joints(), atol=0.1)


def test_dynamixel_servos_move_in_a_time_based_profile():
    with Sim("koch") as sim:
        assert all(s.get("drive_mode") & 4 == 0 for s in sim.emu.servos.values())
        connected(sim)
        assert all(s.get("drive_mode") & 4 for s in sim.emu.servos.values())


@pytest.mark.parametrize("name", ["so101", "koch"])
def test_two_runs_exchange_the_same_bytes_at_the_same_times(name):
    def run():
        with Sim(name) as sim:
            sim.emu.inject("lost_replies", rate=0.05)
            connected(sim)
            sim.until(sim.arm.move_to(np.array([120.0, -60.0, 45.0])))
            return sim.arm.lost_status, list(sim.emu.transcript)

    first = run()
    assert first[0] > 0 and first == run()


def test_a_joint_a_count_past_its_limit_reads_at_the_limit():
    with Sim("so101") as sim:
        connected(sim)
        wrist = sim.arm.spec.joints[3]
        upper = sim.arm.model.upper[3]
        limit_counts = int(np.floor(wrist.calibration.counts(upper)))
        sim.arm.servos[wrist.id].present = limit_counts + 1  # the goal rounded up
        assert sim.arm.joints()[3] == upper
        sim.arm.servos[wrist.id].present = limit_counts + 3  # no rounding: past it
        assert sim.arm.joints()[3] > upper + 0.1


@pytest.mark.slow
def test_one_seed_runs_the_same_run_however_long_the_ticks_take(tmp_path):
    # a tick's skills take wall time (IK, images): the bus must not move meanwhile
    from armtree.runtime.runner import Run

    logs = []
    for k in range(2):
        tree = armtree.load_tree("load_ducky.yaml", rig="sim_so101")
        Run(tree, None, seed=82, record=tmp_path / str(k), max_ticks=300, quiet=True,
            handle_signals=False, stop_key=False).execute()  # fmt: skip
        lines = (tmp_path / str(k) / "run.jsonl").read_text().splitlines()
        logs.append([x for x in lines if '"kind": "status"' in x or '"kind": "event"' in x])
    assert len(logs[0]) > 50 and logs[0] == logs[1]
