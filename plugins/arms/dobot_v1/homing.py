"""Homing the Dobot V1.0 on its original firmware: a board reset re-reads the pose.

The stock V1.0 has no homing switches; its firmware takes its starting pose
from the accelerometers on the rear arm and the forearm, read when the board
boots (Dobot protocol, serial settings; open-dobot, homing). Opening the
serial port resets the board (the Arduino's DTR reset), so a host re-references
the arm by closing and reopening the port: the believed rear-arm and forearm
angles become what the accelerometers read, undoing missed steps of those
joints. The base has no sensor and is believed to be at 0 after a boot, so the
arm is first moved to the model's home configuration with the base at 0.

:class:`BoardResetHoming` is one such homing, carried forward once per tick
by the driver's ``step``: the move, then the reset, then the wait for the
board's first status frames, bounded by the driver's ``connect_timeout``
(run-clock seconds), then the same move again. The first move went where the
board believed the home pose was; the second, with the belief set right,
takes the arm truly there, out of a pose the missed steps may have left
beyond the joints' limits.
"""

from __future__ import annotations

import enum

import numpy as np

from armtree.api.rig import MotionHandle, MotionStatus
from armtree.errors import HardwareFault

from ..common import SerialArmDriver


class Phase(enum.Enum):
    """Where a homing is: moving to the home pose, waiting for the rebooted board, or over."""

    MOVE = "move"
    BOOT = "boot"
    SETTLE = "settle"
    OVER = "over"


def home_pose(home: np.ndarray) -> np.ndarray:
    """The pose a reset leaves believed right: ``home`` (degrees) with the base at 0."""
    pose = np.asarray(home, dtype=float).copy()
    pose[0] = 0.0
    return pose


class BoardResetHoming:
    """One homing of ``driver``: ``move`` (to ``target``, degrees) is under way; ``handle`` reports it.

    With ``reset`` False it ends with the move. :meth:`step` moves it on; the handle is DONE once the reset board has
    moved to ``target`` again, FAILED with a move's error, or with a :class:`HardwareFault`
    naming the port when the board does not come back within the driver's
    ``connect_timeout`` seconds of run clock (the run is then interrupted as on
    a lost link).
    """

    def __init__(
        self,
        driver: SerialArmDriver,
        handle: MotionHandle,
        move: MotionHandle,
        target: np.ndarray,
        reset: bool = True,
    ) -> None:
        self.driver = driver
        self.handle = handle
        self.move = move
        self.target = np.asarray(target, dtype=float).copy()
        #: False: the move alone, no reset (it would drop what the suction holds).
        self.reset = reset
        self.phase = Phase.MOVE
        self.deadline = float("inf")

    def step(self, now: float) -> None:
        """Carry the homing forward at run time ``now`` (s); call once per tick."""
        if self.phase is Phase.MOVE:
            self._after_move(now)
        elif self.phase is Phase.BOOT:
            self._after_reset(now)
        elif self.phase is Phase.SETTLE and self.move.done:
            self._end(self.move.status, self.move.error)

    def stop(self) -> None:
        """The arm was told to stop: a homing still moving ends STOPPED (a reset runs its course)."""
        if self.phase in (Phase.MOVE, Phase.SETTLE):
            self.phase = Phase.OVER
            self.handle.update(MotionStatus.STOPPED)

    def _after_move(self, now: float) -> None:
        if not self.move.done:
            return
        if self.move.status is not MotionStatus.DONE or not self.reset:
            self._end(self.move.status, self.move.error)
            return
        try:
            self.driver.reopen()
        except HardwareFault as exc:
            self._end(MotionStatus.FAILED, exc)
            return
        self.phase = Phase.BOOT
        self.deadline = now + self.driver.connect_timeout
        self.driver.track(self.handle)
        self.handle.update(MotionStatus.RUNNING, 0.5)

    def _after_reset(self, now: float) -> None:
        driver = self.driver
        if driver.fault is not None:
            self._end(MotionStatus.FAILED, driver.fault)
        elif driver.reopened():
            self.handle.description = (
                f"home: moved the base to 0 and reset the board on {driver.device}; "
                "the rear arm and forearm were re-read from the accelerometers"
            )
            self.phase = Phase.SETTLE
            self.move = driver.move_joints(self.target)
            self.handle.update(MotionStatus.RUNNING, 0.75)
        elif now > self.deadline:
            driver.lose_link(
                f"the board did not come back within {driver.connect_timeout:g} s of its "
                "reset (no status frames); check the USB cable and the arm's power switch"
            )
            self._end(MotionStatus.FAILED, driver.fault)

    def _end(self, status: MotionStatus, error: Exception | None) -> None:
        self.phase = Phase.OVER
        self.handle.update(status, error=error)
