"""The simulated world: bodies on a table, the arm from its emulator, Duckybots, scoring.

A :class:`World` is built from a validated :class:`~.scene.SceneSpec` and lives
only in ``RigContext.shared`` (never on the Rig), so skills cannot reach it.
:meth:`World.step` advances it to the run's time after the arm emulators:
it reads the arm's true joints and tool, moves the Duckybots, and hands the
rest to its collaborators: :class:`~.grasping.Grasp` (suction and gripper),
:class:`~.falling.Gravity` (supports, falls, landings) and
:class:`~.contacts.ArmContacts` (collisions). :meth:`World.score` is the ground truth for tests and the run summary.
Every event (pick, release, land, drop, collision, missed step) also goes to
the callables in :attr:`World.listeners` as it happens, and a collision under
``halt_on_collision`` to :attr:`World.on_halt` (the run ends there).

Millimetres and the robot base frame (z up); times are seconds on the run's clock.
"""

from __future__ import annotations

import functools
import math
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from .bodies import ArmView, Body, WorldEvent
from .contacts import ArmContacts
from .duckybot import Duckybot
from .falling import Gravity
from .geometry import point_in_polygon, pose, rot_z
from .grasping import Grasp
from .physics import CollisionMonitor
from .randomize import draw_scene
from .scene import parse_scene
from .scene_spec import SceneSpec
from .scoring import world_score
from .world_parsing import _Errors

#: Step (s) and longest time (s) :meth:`World.settle` lets falling bodies fall.
SETTLE_STEP_S = 0.01
SETTLE_LIMIT_S = 2.0


class World:
    """Ground truth of a simulated run. Thread-safe: step and render may run on two threads."""

    def __init__(self, scene: SceneSpec, seed: int = 0) -> None:
        self.scene = scene
        self.table = scene.table
        self.physics = scene.physics
        self.seed = int(seed)
        self._seq = np.random.SeedSequence([scene.seed, self.seed])
        self.lock = threading.RLock()
        self.time = 0.0
        self.version = 0
        self.bodies: dict[str, Body] = {}
        self.gravity = Gravity(self)
        self.grasp = Grasp(self)
        self.contacts = ArmContacts(self)
        for spec in scene.objects:
            self.bodies[spec.name] = Body(spec, pose(rot_z(spec.yaw), spec.position))
        for spec in scene.objects:
            self.bodies[spec.name].support = self.gravity.support_below(self.bodies[spec.name])[0]
        bot_rng = np.random.default_rng(self._seq.spawn(1)[0])
        self.duckybots: dict[str, Duckybot] = {}
        for bot in scene.duckybots:
            self.bodies[bot.body.name] = Body(
                bot.body, pose(rot_z(bot.body.yaw), bot.body.position)
            )
            name = bot.body.name
            self.duckybots[name] = Duckybot(
                name,
                bot.route.start,
                bot.route.legs,
                bot.params,
                np.random.default_rng(bot_rng.integers(2**63)),
                loaded=functools.partial(self._carries_a_ducky, name),
                loop=bot.route.loop,
            )
        self.emulator: Any = None
        self.model: Any = None
        #: Indices of link boxes that move rigidly with the tool (the end effector).
        self.tool_boxes: frozenset[int] = frozenset()
        self.arm: ArmView | None = None
        #: The arm and the time (s) of the step before the last: where an eye-in-hand
        #: camera was a tick before the frame it renders, for the blur of its motion.
        self.arm_before: ArmView | None = None
        self.time_before = 0.0
        self.collisions = CollisionMonitor(scene.physics.collision_tolerance_mm)
        self._slip_rng = np.random.default_rng(self._seq.spawn(2)[1])
        self._last_joints: list[float] | None = None
        self.events: list[WorldEvent] = []
        #: Called with every event as it happens (the run log listens here).
        self.listeners: list[Callable[[WorldEvent], None]] = []
        #: Called with the reason when a collision halts the arm (``halt_on_collision``).
        self.on_halt: Callable[[str], None] | None = None

    @property
    def held(self) -> str | None:
        """The name of the body the end effector holds, or None."""
        return self.grasp.held

    # -- wiring -------------------------------------------------------------------

    def attach_arm(self, emulator: Any, model: Any = None) -> None:
        """Take the arm's true state from ``emulator`` (a FirmwareEmulator) from now on.

        ``model`` is the arm as built (``world.as_built.arm``), through which its true
        joints place it; by default the emulator's own, the profile's. Faults the
        profile's ``world.faults`` requests are injected into the emulator here.
        """
        with self.lock:
            self.emulator = emulator
            self.model = emulator.model if model is None else model
            self.tool_boxes = _tool_rigid_boxes(self.model)
            self.arm = None
            for fault, options in self.scene.faults.items():
                emulator.inject(fault, **options)
            self._read_arm()

    def _read_arm(self) -> None:
        if self.emulator is None:
            return
        q = np.asarray(self.emulator.true_joints(), dtype=float)
        tool = self.emulator.tool()
        suction, gripper = bool(getattr(tool, "suction", False)), getattr(tool, "gripper", None)
        last = self.arm
        if last is not None and last.joints.tobytes() == q.tobytes():
            # The same joints, bit for bit, place the links exactly as last tick.
            self.arm = ArmView(
                q, last.tool_pose, last.box_poses, last.box_sizes, last.box_names, suction, gripper
            )
            return
        model = self.model
        frames = model.link_frames(q)
        self.arm = ArmView(
            joints=q,
            tool_pose=frames[-1],
            box_poses=model.box_poses_in(frames) if model.boxes else np.zeros((0, 4, 4)),
            box_sizes=model.box_sizes() if model.boxes else np.zeros((0, 3)),
            box_names=tuple(b.name for b in model.boxes),
            suction=suction,
            gripper=gripper,
        )

    # -- stepping -------------------------------------------------------------------

    def step(self, now: float) -> None:
        """Advance the world to ``now`` seconds (after the arm emulators have stepped)."""
        with self.lock:
            dt = max(0.0, now - self.time)
            self.arm_before, self.time_before = self.arm, self.time
            self._read_arm()
            self._missed_steps(dt, now)
            for name, bot in self.duckybots.items():
                before = self.bodies[name].pose.copy()
                bot.advance(now)
                body = self.bodies[name]
                body.pose = pose(rot_z(bot.state.theta), [bot.state.x, bot.state.y, body.bottom])
                carried = self.carried_by(name)
                if carried:
                    delta = body.pose @ np.linalg.inv(before)
                    for other in carried:
                        other.pose = delta @ other.pose
            self.grasp.step(now)
            self.gravity.fall(dt, now)
            self.contacts.check(now)
            self.time = now
            self.version += 1

    def _missed_steps(self, dt: float, now: float) -> None:
        """Random slips of a loaded stepper (``world.faults.missed_steps.rate_per_s``)."""
        slips = self.scene.slips
        arm = self.arm
        if slips is None or arm is None or dt <= 0:
            return
        last = self._last_joints
        current = arm.joints.tolist()
        moving = last is not None and last != current and not _all_close(current, last)
        self._last_joints = current
        if not (moving or self.held is not None):
            return
        if self._slip_rng.random() >= 1.0 - math.exp(-slips.rate * dt):
            return
        joints = slips.joints or tuple(range(len(arm.joints)))
        joint = int(joints[int(self._slip_rng.integers(len(joints)))])
        amount = float(self._slip_rng.uniform(-slips.max_amount, slips.max_amount))
        self.emulator.inject("missed_steps", joint=joint, amount=amount)
        joints = getattr(self.model, "joints", None) or ()
        unit = joints[joint].unit if joint < len(joints) else "deg"
        self.event(now, "missed_steps", {"joint": joint, "amount": round(amount, 4), "unit": unit})

    def start_overlaps(self) -> list[tuple[str, str]]:
        """(link, body) pairs that interpenetrate now: a world placing bodies inside the arm."""
        with self.lock:
            return self.contacts.start_overlaps()

    def event(self, now: float, kind: str, detail: dict[str, Any]) -> None:
        """Record what happened at run time ``now`` and tell the listeners."""
        event = WorldEvent(now, kind, detail)
        self.events.append(event)
        for listener in self.listeners:
            listener(event)

    def settle(self, limit_s: float = SETTLE_LIMIT_S) -> None:
        """Let bodies that are falling land (at most ``limit_s`` s); the arm and Duckybots stay.

        For judging a run that ended the moment something was let go.
        """
        with self.lock:
            waited = 0.0
            while any(b.falling for b in self.bodies.values()) and waited < limit_s:
                waited += SETTLE_STEP_S
                self.gravity.fall(SETTLE_STEP_S, self.time + waited)

    # -- queries --------------------------------------------------------------------

    def _carries_a_ducky(self, name: str) -> bool:
        """Whether a ducky rides on the body ``name`` (a Duckybot's load)."""
        return bool(self.carried_by(name, kinds=("ducky",)))

    def carried_by(self, name: str, kinds: tuple[str, ...] | None = None) -> list[Body]:
        """Bodies resting on ``name``, directly or on top of each other."""
        out: list[Body] = []
        frontier = [name]
        while frontier:
            base = frontier.pop()
            for body in self.bodies.values():
                if body.support == base and not body.held and body not in out:
                    out.append(body)
                    frontier.append(body.name)
        return [b for b in out if kinds is None or b.kind in kinds]

    def in_bin(self, body: Body) -> str | None:
        """The bin whose inside holds ``body`` (through any stack), or None."""
        seen = set()
        current = body
        while current.support not in (None, "table", "floor") and current.support not in seen:
            seen.add(current.support)
            support = self.bodies.get(current.support)
            if support is None:
                return None
            if support.kind == "bin":
                inner = support.footprint(shrink=support.spec.wall)
                return support.name if point_in_polygon(body.pose[:2, 3], inner) else None
            current = support
        return None

    def camera_pose(self, mount: str, extrinsics: np.ndarray) -> np.ndarray:
        """The camera's pose in the base frame: on the tool (eye-in-hand) or fixed."""
        with self.lock:
            if mount == "eye_in_hand":
                if self.arm is None:
                    self._read_arm()
                if self.arm is not None:
                    return self.arm.tool_pose @ extrinsics
            return extrinsics

    def camera_motion(self, mount: str, extrinsics: np.ndarray) -> tuple[np.ndarray, float] | None:
        """Where an eye-in-hand camera was a world step ago (base frame, 4x4 mm) and that
        step's length (s); None for a fixed camera or before the arm has stepped twice."""
        with self.lock:
            before = self.arm_before
            if mount != "eye_in_hand" or before is None or self.time <= self.time_before:
                return None
            return before.tool_pose @ extrinsics, self.time - self.time_before

    def state(self) -> dict[str, Any]:
        """Every body's pose and support and the arm's joints, rounded to 1e-6 mm (for comparisons)."""
        with self.lock:
            return {
                "time": round(self.time, 9),
                "bodies": {
                    n: (b.pose.round(6).tolist(), b.support, b.held)
                    for n, b in sorted(self.bodies.items())
                },
                "arm": None if self.arm is None else self.arm.joints.round(6).tolist(),
            }

    def score(self) -> dict[str, Any]:
        """Ground truth for scoring a run (never for deciding): :func:`~.scoring.world_score`."""
        with self.lock:
            return world_score(self)


#: Key of the world in ``RigContext.shared``.
SHARED_KEY = "sim.world"


def world_for(context: Any) -> World:
    """The rig's simulated world, built from its profile on first use (idempotent).

    The rig's seed draws the world from ``world.randomize`` (seed 0: the nominal one).

    Raises :class:`armtree.ConfigError` naming the entry when the profile's
    ``world:`` section is invalid.
    """
    world = context.shared.get(SHARED_KEY)
    if world is None:
        scene = draw_scene(parse_scene(context.profile), context.seed, _Errors(context.profile))
        world = World(scene, seed=context.seed)
        context.shared[SHARED_KEY] = world
    return world


def _all_close(a: list[float], b: list[float]) -> bool:
    """``np.allclose(a, b)`` (rtol 1e-5, atol 1e-8) of two equally long lists of floats.

    The same comparisons in plain floats: the world asks this every tick, where
    NumPy's call costs far more than three to six comparisons.
    """
    return all(
        x == y or (abs(x - y) <= 1e-08 + 1e-05 * abs(y) and math.isfinite(y))
        for x, y in zip(a, b, strict=True)
    )


def _tool_rigid_boxes(model: Any) -> frozenset[int]:
    """Link boxes that keep their pose relative to the tool in three sample configurations."""
    if not model.boxes:
        return frozenset()
    lower, upper = np.asarray(model.lower, dtype=float), np.asarray(model.upper, dtype=float)
    samples = [lower + f * (upper - lower) for f in (0.3, 0.5, 0.8)]
    relative = []
    for q in samples:
        tool = np.linalg.inv(model.fk(q))
        relative.append(tool @ model.box_poses(q))
    return frozenset(
        i
        for i in range(len(model.boxes))
        if all(np.allclose(relative[0][i], r[i], atol=1e-6) for r in relative[1:])
    )
