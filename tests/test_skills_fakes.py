"""Small fakes of the rig interfaces for driving skills tick by tick, and tests of the fakes.

The fake arm is a cylindrical robot (base angle in degrees, reach and height in
mm) whose tool turns with the base like the Dobot's; motions finish after a
set number of ticks. The fake camera rides on the tool looking down; the fake
tracker reports every marker of the fake world inside the camera's field of
view with its pose in the camera frame, as a real tracker would from an image.
Only the fakes look at the world; the skills see frames and detections.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import py_trees
import pytest
from py_trees.common import Status

from armtree.api.clock import VirtualClock
from armtree.api.rig import (
    ArmDriver,
    Camera,
    Detection,
    Frame,
    MotionHandle,
    MotionStatus,
    Planner,
    Rig,
    TagSpec,
    ToolState,
    Tracker,
)
from armtree.errors import PlanningError, Unreachable
from armtree.maths.motion.kinematics import Joint, KinematicModel

TICK = 0.05
#: Camera in the tool frame: 20 mm to the side, 30 mm up, looking down (Showers 2016's R_TC).
TOOL_T_CAMERA = np.array(
    [[0.0, 1.0, 0.0, -10.0], [1.0, 0.0, 0.0, -20.0], [0.0, 0.0, -1.0, 30.0], [0.0, 0.0, 0.0, 1.0]]
)
TAGS = {
    "ducky": TagSpec("ducky", (0,), 25.0),
    "duckybot": TagSpec("duckybot", (1,), 25.0),
    "trash": TagSpec("trash", (2, 3, 4), 25.0),
    "tool": TagSpec("tool", (5,), 25.0),
}
PLACES = {
    "home": [200.0, 0.0, 80.0],
    "ducky_pickup": [180.0, -160.0, 0.0],
    "garbage_bin": [60.0, 230.0, 40.0],
}

#: The fake rig's task geometry: a ring of r = 200 mm on the table top at z = 0.
WORKCELL = {"table_z_mm": 0.0, "look_height_mm": 120.0, "survey": {"ring": {"radius_mm": 200.0}}}


def rz(deg: float) -> np.ndarray:
    """4x4 rotation about z by ``deg`` degrees."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    out = np.eye(4)
    out[:2, :2] = [[c, -s], [s, c]]
    return out


class CylModel(KinematicModel):
    """Base angle (deg), reach (mm), height (mm); the tool turns with the base."""

    name = "cyl"
    joints = (
        Joint("base", "revolute", -135.0, 135.0, 90.0),
        Joint("reach", "prismatic", 80.0, 320.0, 200.0),
        Joint("height", "prismatic", -60.0, 220.0, 200.0),
    )
    home = np.array([0.0, 200.0, 80.0])

    def link_frames(self, q: np.ndarray) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        th = np.radians(q[..., 0])
        frame = np.zeros((*q.shape[:-1], 1, 4, 4))
        frame[..., 0, 0, 0] = np.cos(th)
        frame[..., 0, 0, 1] = -np.sin(th)
        frame[..., 0, 1, 0] = np.sin(th)
        frame[..., 0, 1, 1] = np.cos(th)
        frame[..., 0, 2, 2] = 1.0
        frame[..., 0, 3, 3] = 1.0
        frame[..., 0, 0, 3] = q[..., 1] * np.cos(th)
        frame[..., 0, 1, 3] = q[..., 1] * np.sin(th)
        frame[..., 0, 2, 3] = q[..., 2]
        return frame

    def ik_all(self, target: np.ndarray) -> np.ndarray:
        t = np.asarray(target, dtype=float)
        q = np.stack(
            [
                np.degrees(np.arctan2(t[..., 1], t[..., 0])),
                np.hypot(t[..., 0], t[..., 1]),
                t[..., 2],
            ],
            -1,
        )
        q = np.where(self.within_limits(q)[..., None], q, np.nan)
        return q[..., None, :]


@dataclass
class Marker:
    """A marker of the fake world: id, base position (mm), velocity (mm/s) until ``stop_at`` s."""

    id: int
    position: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    stop_at: float = 0.0
    held: bool = False
    #: Where a held marker sits relative to the tool centre (base axes, mm).
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    dropped_at: np.ndarray | None = None


class World:
    """Ground truth of the fakes: markers, and what the suction cup holds."""

    def __init__(self, markers: list[Marker]) -> None:
        self.markers = {m.id: m for m in markers}
        self.held: Marker | None = None

    def step(self, now: float, dt: float, tool: np.ndarray) -> None:
        for m in self.markers.values():
            if m.held:
                m.position = tool + m.offset
            elif now < m.stop_at:
                m.position = m.position + m.velocity * dt

    def grip(self, tool: np.ndarray) -> None:
        for m in self.markers.values():
            if np.linalg.norm(m.position - tool) < 5.0:
                m.held = True
                self.held = m
                return

    def release(self, tool: np.ndarray) -> None:
        if self.held is not None:
            self.held.held = False
            self.held.dropped_at = tool.copy()
            self.held = None


class FakeArm(ArmDriver):
    """An arm whose moves end after ``ticks`` steps; refuses targets outside its limits."""

    device = "fake"

    def __init__(self, world: World, ticks: int = 2, q: np.ndarray | None = None) -> None:
        self.model = CylModel()
        self.world = world
        self.ticks = ticks
        self.q = np.array(self.model.home if q is None else q, dtype=float)
        self.suction = False
        #: Joint error the arm does not know about (lost steps): actual = reported + bias.
        self.bias = np.zeros(3)
        self.moves: list[np.ndarray] = []
        self.stops = 0
        self.fail_next_move = False
        self._motion: tuple[MotionHandle, np.ndarray, int] | None = None
        self._tool: tuple[MotionHandle, bool] | None = None

    def connect(self) -> None:
        return None

    def close(self) -> None:
        return None

    def joints(self) -> np.ndarray:
        return self.q.copy()

    def move_joints(self, q: np.ndarray, speed: float = 1.0) -> MotionHandle:
        q = np.asarray(q, dtype=float)
        handle = MotionHandle("move", q)
        if not self.model.within_limits(q):
            handle.update(
                MotionStatus.FAILED, error=Unreachable(f"joints {q.tolist()} out of limits")
            )
            return handle
        if self.fail_next_move:
            self.fail_next_move = False
            handle.update(MotionStatus.FAILED, error=RuntimeError("link lost"))
            return handle
        self.moves.append(q)
        self._motion = (handle, q, self.ticks)
        return handle

    def move_to(self, xyz: np.ndarray, speed: float = 1.0) -> MotionHandle:
        try:
            q = self.model.ik(xyz, near=self.q)
        except Unreachable as exc:
            handle = MotionHandle("move")
            handle.update(MotionStatus.FAILED, error=exc)
            return handle
        return self.move_joints(q, speed)

    def set_suction(self, on: bool) -> MotionHandle:
        handle = MotionHandle("suction")
        self._tool = (handle, on)
        return handle

    def stop(self) -> None:
        self.stops += 1
        if self._motion is not None:
            self._motion[0].update(MotionStatus.STOPPED)
            self._motion = None

    @property
    def tool(self) -> ToolState:
        return ToolState(suction=self.suction)

    def actual_pose(self) -> np.ndarray:
        """Where the tool really is (the world and camera use this, not the readings)."""
        return self.model.fk(self.q + self.bias)

    def step(self) -> None:
        if self._motion is not None:
            handle, q, left = self._motion
            if left <= 1:
                self.q = q
                self._motion = None
                handle.update(MotionStatus.DONE)
            else:
                self._motion = (handle, q, left - 1)
                handle.update(MotionStatus.RUNNING)
        if self._tool is not None:
            handle, on = self._tool
            self._tool = None
            self.suction = on
            tip = self.actual_pose()[:3, 3]
            if on:
                self.world.grip(tip)
            else:
                self.world.release(tip)
            handle.update(MotionStatus.DONE)


class FakeCamera(Camera):
    """One frame per tick, stamped with the clock; remembers the tool pose it was taken at."""

    mount = "eye_in_hand"

    def __init__(self, clock: VirtualClock, arm: FakeArm, mount: str = "eye_in_hand") -> None:
        self.clock = clock
        self.arm = arm
        self.mount = mount
        self.extrinsics = TOOL_T_CAMERA.copy() if mount == "eye_in_hand" else _fixed_camera()
        self.poses: dict[int, np.ndarray] = {}
        self._last = -1.0
        self._index = 0

    def start(self) -> None:
        return None

    def read(self) -> Frame | None:
        now = self.clock.now()
        if now <= self._last:
            return None
        self._last = now
        self._index += 1
        tool = self.arm.actual_pose()
        self.poses[self._index] = (
            tool @ self.extrinsics if self.mount == "eye_in_hand" else self.extrinsics
        )
        return Frame(_IMAGE, now, _K.copy(), np.zeros(5), self._index)


#: The fake camera's image (never drawn on) and intrinsics: the 640x480, fx = 810 view the
#: fake tracker reports markers in.
_IMAGE = np.zeros((480, 640), np.uint8)
_K = np.array([[810.0, 0.0, 320.0], [0.0, 810.0, 240.0], [0.0, 0.0, 1.0]])


def _fixed_camera() -> np.ndarray:
    """A camera 600 mm above (150, 0), looking straight down."""
    pose = np.eye(4)
    pose[:3, :3] = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]
    pose[:3, 3] = [150.0, 0.0, 600.0]
    return pose


class FakeTracker(Tracker):
    """Reports the world's markers inside a 640x480 view (fx 810) as camera-frame poses."""

    def __init__(
        self, world: World, camera: FakeCamera, noise_mm: float = 0.0, seed: int = 0
    ) -> None:
        self.world = world
        self.camera = camera
        self.noise = noise_mm
        self.rng = np.random.default_rng(seed)
        self.blind_frames = 0
        #: No marker is seen from a camera lower than this (mm): the tool hides them there.
        self.blind_below_z = -np.inf
        self.calls = 0

    def detect(self, frame: Frame) -> list[Detection]:
        self.calls += 1
        if self.blind_frames > 0:
            self.blind_frames -= 1
            return []
        cam = self.camera.poses[frame.index]
        if cam[2, 3] < self.blind_below_z:
            return []
        inv = np.linalg.inv(cam)
        out = []
        for m in self.world.markers.values():
            p = inv[:3, :3] @ m.position + inv[:3, 3]
            if p[2] <= 20.0 or abs(p[0] / p[2]) > 320 / 810 or abs(p[1] / p[2]) > 240 / 810:
                continue
            if self.noise:
                p = p + self.rng.normal(0.0, self.noise, 3)
            out.append(Detection(m.id, np.zeros((4, 2)), rvec=np.zeros(3), tvec=p, size_mm=25.0))
        return out


class FakePlanner(Planner):
    """Straight joint paths with one midpoint; a tool below z = -40 mm collides with the table."""

    def __init__(self, model: KinematicModel) -> None:
        self.model = model
        self.calls = 0

    def plan(self, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
        self.calls += 1
        if self.model.position(goal)[2] < -40.0:
            raise PlanningError("goal in collision with the table", reason="goal_in_collision")
        start, goal = np.asarray(start, float), np.asarray(goal, float)
        return np.stack([start, (start + goal) / 2, goal])


class FakeRig(Rig):
    """A rig of fakes whose :meth:`step` advances the arm and the world by one tick."""

    world: World

    def step(self, now: float) -> None:
        self.arm.step()
        self.world.step(now, TICK, self.arm.actual_pose()[:3, 3])


def make_rig(
    markers: list[Marker] | None = None,
    planner: bool = True,
    camera: bool = True,
    mount: str = "eye_in_hand",
    ticks: int = 2,
    noise_mm: float = 0.0,
    workcell: dict | None = None,
) -> FakeRig:
    """A fake rig with the given world markers; ``workcell`` entries replace those of
    :data:`WORKCELL` in its profile."""
    clock = VirtualClock()
    world = World(markers or [])
    arm = FakeArm(world, ticks=ticks)
    cam = FakeCamera(clock, arm, mount) if camera else None
    rig = FakeRig(
        profile={"workcell": {**WORKCELL, **(workcell or {})}},
        clock=clock,
        arm=arm,
        camera=cam,
        tracker=FakeTracker(world, cam, noise_mm) if cam else None,
        planner=FakePlanner(arm.model) if planner else None,
        tags=dict(TAGS),
        places={k: list(v) for k, v in PLACES.items()},
    )
    rig.world = world
    return rig


def run(
    root: py_trees.behaviour.Behaviour, rig: FakeRig, max_ticks: int = 2000
) -> tuple[Status, int]:
    """Tick ``root`` on ``rig`` until it ends; the final status and the ticks taken."""
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup(rig=rig, clock=rig.clock)
    for n in range(1, max_ticks + 1):
        tree.tick()
        if root.status in (Status.SUCCESS, Status.FAILURE):
            return root.status, n
        rig.clock.advance(TICK)
        rig.step(rig.clock.now())
    return root.status, max_ticks


@pytest.fixture(autouse=True)
def _clean_blackboard():
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


def test_fake_model_ik_inverts_fk():
    model = CylModel()
    q = np.array([30.0, 210.0, 15.0])
    assert np.allclose(model.ik(model.position(q)), q)
    with pytest.raises(Unreachable):
        model.ik(np.array([0.0, 0.0, 0.0]))


def test_fake_arm_move_ends_after_its_ticks():
    rig = make_rig(ticks=3)
    handle = rig.arm.move_joints(np.array([10.0, 200.0, 50.0]))
    for _ in range(2):
        rig.step(0.0)
        assert not handle.done
    rig.step(0.0)
    assert handle.status is MotionStatus.DONE and rig.arm.q[0] == 10.0


def test_fake_tracker_sees_a_marker_below_the_camera_only():
    rig = make_rig([Marker(1, np.array([200.0, 0.0, 0.0]))])
    rig.clock.advance(TICK)
    frame = rig.camera.read()
    dets = rig.tracker.detect(frame)
    assert [d.id for d in dets] == [1]
    rig.arm.q = np.array([90.0, 200.0, 80.0])
    rig.clock.advance(TICK)
    assert rig.tracker.detect(rig.camera.read()) == []
