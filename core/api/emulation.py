"""The contract between an arm's firmware emulator and the simulated world.

An arm plugin started with ``port: sim`` builds its emulator, serves it on a
pseudo-terminal, points its own serial driver at that device, appends
:meth:`FirmwareEmulator.step` to ``context.steppers`` and publishes the emulator
as ``context.shared["sim.arm"]``. The simulation plugin reads the arm's true
state from it (for rendering, suction and scoring) and may stop it on a crash.
Skills never see it: they only get the driver.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from armtree.maths.motion.kinematics import KinematicModel

from .rig import ToolState

#: Key under which an arm plugin publishes its emulator in ``RigContext.shared``.
SHARED_KEY = "sim.arm"


class FirmwareEmulator(ABC):
    """One arm's firmware, byte for byte, behind a pseudo-terminal.

    Joint units are degrees / mm; times are seconds on the run's clock.
    """

    model: KinematicModel

    @abstractmethod
    def start(self) -> str:
        """Open the pseudo-terminal and return the device path a driver opens."""

    @abstractmethod
    def step(self, now: float) -> None:
        """Handle every byte received, move the joints up to ``now`` and send what is due.

        On a virtual clock it returns only once the driver has written nothing
        more and has read everything sent, so a run is deterministic.
        """

    @abstractmethod
    def close(self) -> None:
        """Stop serving and close the pseudo-terminal."""

    @abstractmethod
    def true_joints(self) -> np.ndarray:
        """Where the joints really are (they differ from the report after missed steps)."""

    @abstractmethod
    def tool(self) -> ToolState:
        """Suction and gripper as the firmware drives them."""

    @abstractmethod
    def halt(self, reason: str) -> None:
        """Stop the arm where it is, as a crash or an e-stop would."""

    def inject(self, fault: str, **options: float) -> None:
        """Inject a fault: ``"corrupt"``, ``"drop"``, ``"cut"`` or ``"missed_steps"``."""
        raise ValueError(f"{type(self).__name__} does not support fault {fault!r}")
