"""``armtree calibrate servos --rig P``: each servo's homing offset and range, moved by hand.

As LeRobot users already calibrate their arms: with torque off,

1. the servos' homing offsets are set to 0, so each reports where its horn is;
2. the operator holds the arm in its zero pose (the URDF's: for an SO-101 the upper
   arm straight up, forearm and gripper level and straight ahead, jaws closed);
   each servo's homing offset is written so that this pose reads 2048;
3. the operator moves every joint through its whole range, slowly; the lowest and
   highest present positions are the range.

On a simulated rig (``port: sim``) a simulated hand does the moving: it holds the
arm at zero, then sweeps every joint from one URDF limit to the other. The result
is the ``arm.calibration`` section the calibration file holds. Times are wall
seconds: this runs against a device, or an emulator serving itself.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from armtree.api.clock import WallClock
from armtree.api.emulation import SHARED_KEY
from armtree.api.rig import MotionHandle, MotionStatus, RigContext
from armtree.errors import HardwareFault
from armtree.loader.profile import Profile

from .calibration import MIDDLE, ServoCalibration
from .driver import BusServoDriver
from .spec import ArmSpec
from .tables import COUNTS_PER_TURN

#: Steps of the simulated hand's sweep through each joint's range, and wall seconds each.
SWEEP_STEPS = 24
SWEEP_STEP_S = 0.03
#: Wall seconds a write or a read of every servo may take.
WAIT_S = 3.0


def calibrate_servos(
    factory: Any,
    config: dict[str, Any],
    profile: Profile,
    *,
    ready: Callable[[str], None],
    say: Callable[[str], None] = print,
) -> dict[str, ServoCalibration]:
    """Calibrate the arm ``factory`` builds from ``config`` (its ``calibration`` ignored).

    ``ready(text)`` shows an instruction and returns once the operator has done it
    (press Enter); on the simulation it is only shown. Raises :class:`HardwareFault`
    naming the device when the bus does not answer.
    """
    config = {k: v for k, v in config.items() if k != "calibration"}
    spec: ArmSpec = factory.spec(config)
    context = RigContext(profile=profile, clock=WallClock())
    driver: BusServoDriver = factory(config, context)
    driver.hold = False
    hand = context.shared.get(SHARED_KEY)
    try:
        driver.connect()
        _wait(driver, driver.write_registers("homing_offset", {i: 0 for i in spec.ids}))
        zero = _zero_pose(driver, spec, hand, ready, say)
        offsets = {}
        for link in spec.links:
            wanted = link.model.offset_sign * (MIDDLE - zero[link.id])
            reg = link.model.register("homing_offset")
            limit = (1 << reg.encoding) - 1 if reg.encoding and reg.encoding > 0 else 1 << 20
            offsets[link.id] = int(np.clip(wanted, -limit, limit))
        _wait(driver, driver.write_registers("homing_offset", offsets))
        low, high = _ranges(driver, spec, hand, ready, say)
    finally:
        for closer in [driver.close, *reversed(context.closers)]:
            closer()
    return {
        link.joint: ServoCalibration(
            link.id,
            link.calibration.drive_mode,
            offsets[link.id],
            int(min(max(low[link.id], 0), COUNTS_PER_TURN - 2)),
            int(min(max(high[link.id], 1), COUNTS_PER_TURN - 1)),
        )
        for link in spec.links
    }


def _zero_pose(
    driver: BusServoDriver,
    spec: ArmSpec,
    hand: Any,
    ready: Callable[[str], None],
    say: Callable[[str], None],
) -> dict[int, int]:
    names = ", ".join(s.joint for s in spec.links)
    if hand is not None:
        say("simulated: the hand holds the arm in its zero pose")
        hand.turn_by_hand([0.0] * len(spec.joints), 0.0 if spec.gripper else None)
    else:
        ready(
            f"With torque off, hold the arm in its zero pose (the URDF's: {names} at 0) "
            "and press Enter"
        )
    return _settled_read(driver)


def _ranges(
    driver: BusServoDriver,
    spec: ArmSpec,
    hand: Any,
    ready: Callable[[str], None],
    say: Callable[[str], None],
) -> tuple[dict[int, int], dict[int, int]]:
    start = _settled_read(driver)
    low, high = dict(start), dict(start)

    def sample() -> None:
        for i, p in driver.present().items():
            if p is not None:
                low[i], high[i] = min(low[i], p), max(high[i], p)

    if hand is not None:
        say("simulated: the hand moves every joint through its whole range")
        lower, upper = driver.model.lower, driver.model.upper
        grip = spec.gripper
        for k in range(SWEEP_STEPS + 1):
            f = k / SWEEP_STEPS
            angles = (lower + f * (upper - lower)).tolist()
            hand.turn_by_hand(angles, None if grip is None else 100.0 * f)
            time.sleep(SWEEP_STEP_S)
            sample()
        return low, high
    say("Move every joint slowly through its whole range, end to end; press Enter when done")
    done = _background_enter(ready)
    while not done():
        time.sleep(driver.poll_period)
        _check(driver)
        sample()
    return low, high


def _background_enter(ready: Callable[[str], None]) -> Callable[[], bool]:
    """Wait for Enter on a thread (sampling goes on meanwhile); True once pressed."""
    import threading

    pressed = threading.Event()

    def wait() -> None:
        ready("")
        pressed.set()

    threading.Thread(target=wait, daemon=True).start()
    return pressed.is_set


def _settled_read(driver: BusServoDriver) -> dict[int, int]:
    """Every servo's present position once two full reads after now agree (counts)."""
    deadline = time.monotonic() + WAIT_S
    last: dict[int, int | None] = {}
    while time.monotonic() < deadline:
        time.sleep(max(driver.poll_period, 0.02) * 2)
        _check(driver)
        now = driver.present()
        if all(v is not None for v in now.values()) and now == last:
            return {i: int(v) for i, v in now.items() if v is not None}
        last = now
    raise HardwareFault(
        "the servos' positions did not settle: is the arm held still?", driver.device
    )


def _wait(driver: BusServoDriver, handle: MotionHandle) -> None:
    if not handle.wait(WAIT_S) or handle.status is not MotionStatus.DONE:
        _check(driver)
        raise HardwareFault(f"{handle.description}: not confirmed by every servo", driver.device)


def _check(driver: BusServoDriver) -> None:
    if driver.fault is not None:
        raise driver.fault


__all__ = ["calibrate_servos"]
