"""ArmTool.holding (what skills read as rig.tool.holding): what the arm reports about its
tool, read the way the mounted tool means it.

Issue 12's loose end: a Dobot V1.0 reports a gripper angle in every status frame
whatever is mounted, so a suction-cup V1 reading gripper 0.0 with the pump off
was taken for a closed gripper ("engaged").
"""

from __future__ import annotations

import numpy as np

from armtree.api.clock import VirtualClock
from armtree.api.rig import ArmTool
from armtree.plugins.arms.common.plausibility import STABLE_FRAMES
from armtree.plugins.arms.dh import ssc32 as S
from armtree.plugins.arms.dh.driver import SSC32Driver
from armtree.plugins.arms.dh.kinematics import DHModel, DHRow
from armtree.plugins.arms.dobot_v1 import codec
from armtree.plugins.arms.dobot_v1.driver import DobotV1Driver
from armtree.plugins.arms.dobot_v1.kinematics import DobotV1Model


def v1_reporting(is_grab: float, gripper: float) -> DobotV1Driver:
    """A V1.0 driver (suction cup) that has read a few status frames with these tool fields."""
    model = DobotV1Model()
    driver = DobotV1Driver(model, "/dev/null-tool", baud=9600, clock=VirtualClock())
    home = np.asarray(model.home, dtype=float)
    x, y, z = model.position(home).tolist()
    for i in range(STABLE_FRAMES):
        driver._now = 0.05 * i
        driver.on_data(codec.Status(x, y, z, 0.0, *home, 0.0, is_grab, gripper).encode())
    assert driver.tool.gripper == gripper  # the frame was believed
    return driver


def test_a_v1_suction_cup_reading_gripper_zero_with_the_pump_off_is_not_engaged() -> None:
    assert not ArmTool(v1_reporting(is_grab=0.0, gripper=0.0)).holding
    assert ArmTool(v1_reporting(is_grab=1.0, gripper=0.0)).holding


def test_a_gripper_is_engaged_when_nearer_closed_than_open() -> None:
    model = DHModel([DHRow(0, 0, 0), DHRow(100, 0, 0)], [(-90, 90)] * 2, "modified")
    maps = S.servo_maps_from_config(None, 3)
    driver = SSC32Driver(
        model, "/dev/null-tool", maps[:2], gripper=maps[2], grip_angles=(0.0, 60.0),
        clock=VirtualClock(),
    )  # fmt: skip
    assert driver.tool_kind == "gripper"
    for reading, engaged in ((5.0, True), (50.0, False)):
        driver._gripper_readback = reading
        assert ArmTool(driver).holding is engaged
