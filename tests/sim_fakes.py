"""A small cylindrical arm and a stand-in firmware emulator for the sim tests.

The arm: base yaw (deg), reach (mm) and height (mm) of a level tool, like the
Dobot's level end effector. The emulator holds its joints where a test puts
them (or moves them at a fixed speed toward a target on the run's clock).
"""

from __future__ import annotations

import numpy as np

from armtree.api.emulation import FirmwareEmulator
from armtree.api.rig import ToolState
from armtree.maths.motion.kinematics import Joint, KinematicModel, LinkBox


def _tf(yaw_deg: float, xyz) -> np.ndarray:
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    t = np.eye(4)
    t[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    t[:3, 3] = xyz
    return t


def _shift(xyz) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = xyz
    return t


class CylinderArm(KinematicModel):
    """q = (yaw deg, reach mm, height mm); frames: base, column top, tool centre point."""

    name = "cylinder"

    def __init__(self) -> None:
        self.joints = (
            Joint("yaw", "revolute", -135, 135, 90, 360),
            Joint("reach", "prismatic", 100, 350, 200, 800),
            Joint("height", "prismatic", -20, 250, 200, 800),
        )
        self.home = np.array([0.0, 200.0, 120.0])
        self.boxes = (
            LinkBox("column", 0, (60.0, 60.0, 100.0), _shift([0, 0, 50])),
            LinkBox("boom", 1, (100.0, 30.0, 30.0), _shift([-60, 0, 0])),
            LinkBox("tool", 2, (24.0, 24.0, 40.0), _shift([0, 0, 20])),
        )

    def link_frames(self, q):
        q = np.asarray(q, dtype=float)
        flat = q.reshape(-1, 3)
        out = np.empty((len(flat), 3, 4, 4))
        for i, (yaw, reach, height) in enumerate(flat):
            base = _tf(yaw, [0, 0, 0])
            boom = _tf(yaw, [0, 0, 0]) @ _shift([reach, 0, height + 60])
            tool = _tf(yaw, [0, 0, 0]) @ _shift([reach, 0, height])
            out[i] = [base, boom, tool]
        return out.reshape(q.shape[:-1] + (3, 4, 4))

    def ik_all(self, target):
        target = np.asarray(target, dtype=float)
        yaw = np.degrees(np.arctan2(target[..., 1], target[..., 0]))
        reach = np.hypot(target[..., 0], target[..., 1])
        q = np.stack([yaw, reach, target[..., 2]], axis=-1)[..., None, :]
        ok = self.within_limits(q)
        return np.where(ok[..., None], q, np.nan)


class FakeEmulator(FirmwareEmulator):
    """Joints and tool set by the test; records halts and injected faults."""

    def __init__(self, model: KinematicModel | None = None) -> None:
        self.model = model or CylinderArm()
        self.q = np.array(self.model.home, dtype=float)
        self.target = self.q.copy()
        self.speed = 100.0
        self.suction = False
        self.gripper: float | None = None
        self.halted: list[str] = []
        self.injected: list[tuple[str, dict]] = []
        self.now = 0.0

    def start(self) -> str:
        return "/dev/null"

    def step(self, now: float) -> None:
        dt = max(0.0, now - self.now)
        self.now = now
        if self.halted:
            return
        delta = self.target - self.q
        dist = float(np.linalg.norm(delta))
        if dist > 0:
            self.q = self.q + delta * min(1.0, self.speed * dt / dist)

    def close(self) -> None:
        pass

    def true_joints(self) -> np.ndarray:
        return self.q.copy()

    def tool(self) -> ToolState:
        return ToolState(suction=self.suction, gripper=self.gripper)

    def halt(self, reason: str) -> None:
        self.halted.append(reason)
        self.target = self.q.copy()

    def inject(self, fault: str, **options: float) -> None:
        self.injected.append((fault, options))

    def put(self, xyz) -> None:
        """Place the tool at ``xyz`` (mm) at once."""
        self.q = self.model.ik(np.asarray(xyz, dtype=float))
        self.target = self.q.copy()


# The Dobot report's Logitech C270 (Showers 2016, Fig. 10).
C270 = {
    "mount": "eye_in_hand",
    "width": 640,
    "height": 480,
    "fps": 30,
    "intrinsics": {"fx": 810.06, "fy": 810.76, "cx": 325.40, "cy": 249.02},
    "distortion": [0.01584, 0.37926, -0.00056, 0.00331, 0],
}

#: The sim tests' step (s): the default tick of a 20 Hz tree.
DT = 0.05


def run_world(world, emulator, seconds: float, t0: float | None = None) -> float:
    """Step the emulator, then the world, every DT for ``seconds``; the time reached (s)."""
    t = world.time if t0 is None else t0
    end = t + seconds
    while t < end - 1e-9:
        t = round(t + DT, 9)
        emulator.step(t)
        world.step(t)
    return t
