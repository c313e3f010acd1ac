"""The simulated world: bodies on a table, the arm from its emulator, Duckybots, scoring.

A :class:`World` is built from a validated :class:`~.scene.SceneSpec` and lives
only in ``RigContext.shared`` (never on the Rig), so skills cannot reach it.
:meth:`World.step` advances it to the run's time after the arm emulators:
it reads the arm's true joints and tool, moves the Duckybots, applies
suction and gripper physics, lets released objects fall and records
collisions. :meth:`World.score` is the ground truth for tests and the run summary.
Every event (pick, release, land, drop, collision, missed step) also goes to
the callables in :attr:`World.listeners` as it happens, and a collision under
``halt_on_collision`` to :attr:`World.on_halt` (the run ends there).

Millimetres and the robot base frame (z up); times are seconds on the run's clock.
"""

from __future__ import annotations

import dataclasses
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .duckybot import Duckybot
from .geometry import obb_penetration, point_in_polygon, pose, rot_z
from .physics import CollisionMonitor, SolidBox
from .randomize import draw_scene
from .scene import MarkerSpec, ObjectSpec, SceneSpec, _Errors, parse_scene

#: Kinds an end effector can lift.
MOVABLE = ("ducky", "trash", "block")
#: Gravity, mm/s^2.
GRAVITY = 9810.0
#: Where an object that falls off the table ends up, below the table top (mm).
FLOOR_DROP = 750.0
#: A fall longer than this (mm) outside a bin is a drop: a place let go too high.
DROP_MM = 15.0
#: Step (s) and longest time (s) :meth:`World.settle` lets falling bodies fall.
SETTLE_STEP_S = 0.01
SETTLE_LIMIT_S = 2.0


@dataclass
class Body:
    """An object's state: ``pose`` is the 4x4 pose of its bottom-face centre (mm)."""

    spec: ObjectSpec
    pose: np.ndarray
    support: str | None = "table"
    held: bool = False
    falling: bool = False
    vz: float = 0.0
    off_table: bool = False
    #: Height of its bottom (mm) when it started to fall.
    fall_from: float = 0.0
    #: :meth:`solids` as last built, and the pose and size it was built for.
    _solids_memo: tuple[bytes, list[SolidBox]] | None = field(
        default=None, repr=False, compare=False
    )

    @property
    def name(self) -> str:
        """The name given in the profile."""
        return self.spec.name

    @property
    def kind(self) -> str:
        """ducky, trash, obstacle, bin, spot or duckybot."""
        return self.spec.kind

    @property
    def size(self) -> np.ndarray:
        """(x, y, z) extents, mm."""
        return self.spec.size

    @property
    def marker(self) -> MarkerSpec | None:
        """The marker on its top face, if any."""
        return self.spec.marker

    @property
    def bottom(self) -> float:
        """Height of its lowest point, mm (bodies are kept level except while held)."""
        return float(self.pose[2, 3])

    @property
    def top(self) -> float:
        """Height of its top face, mm."""
        return float(self.pose[2, 3] + self.size[2])

    @property
    def yaw(self) -> float:
        """Heading about z, radians."""
        return math.atan2(self.pose[1, 0], self.pose[0, 0])

    def center_pose(self) -> np.ndarray:
        """4x4 pose of the body's centre."""
        return self.pose @ pose(np.eye(3), [0.0, 0.0, 0.5 * self.size[2]])

    def top_pose(self) -> np.ndarray:
        """4x4 pose of the top-face centre: the marker frame (x, y in the face, z up)."""
        return self.pose @ pose(np.eye(3), [0.0, 0.0, self.size[2]])

    def footprint(self, shrink: float = 0.0) -> np.ndarray:
        """Footprint corners (4, 2) in the table plane, optionally shrunk by ``shrink`` mm."""
        hx, hy = 0.5 * self.size[0] - shrink, 0.5 * self.size[1] - shrink
        local = np.array([[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0]], dtype=float)
        return (local @ self.pose[:3, :3].T + self.pose[:3, 3])[:, :2]

    def solids(self) -> list[SolidBox]:
        """Collision boxes: one for a solid, five (floor and walls) for a bin, none for a spot."""
        # Rebuilt only when the pose or size changed: most bodies rest for most of a run.
        key = self.pose.tobytes() + self.size.tobytes()
        if self._solids_memo is None or self._solids_memo[0] != key:
            self._solids_memo = (key, self._build_solids())
        return list(self._solids_memo[1])

    def _build_solids(self) -> list[SolidBox]:
        if self.kind == "spot":
            return []
        if self.kind != "bin":
            return [SolidBox(self.name, self.center_pose(), self.size)]
        sx, sy, sz = self.size
        w = self.spec.wall
        parts = [
            ((0, 0, w / 2), (sx, sy, w)),
            ((sx / 2 - w / 2, 0, sz / 2), (w, sy, sz)),
            ((-sx / 2 + w / 2, 0, sz / 2), (w, sy, sz)),
            ((0, sy / 2 - w / 2, sz / 2), (sx, w, sz)),
            ((0, -sy / 2 + w / 2, sz / 2), (sx, w, sz)),
        ]
        return [SolidBox(self.name, self.pose @ pose(np.eye(3), c), np.array(s)) for c, s in parts]


@dataclass
class ArmView:
    """The arm as the world sees it at one instant: joints, tool pose, link boxes."""

    joints: np.ndarray
    tool_pose: np.ndarray
    box_poses: np.ndarray
    box_sizes: np.ndarray
    box_names: tuple[str, ...]
    suction: bool = False
    gripper: float | None = None


@dataclass
class WorldEvent:
    """Something that happened, for the run summary: pick, release, land, collision."""

    time: float
    kind: str
    detail: dict[str, Any] = field(default_factory=dict)


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
        for spec in scene.objects:
            self.bodies[spec.name] = Body(spec, pose(rot_z(spec.yaw), spec.position))
        for spec in scene.objects:
            self.bodies[spec.name].support = self._support_below(self.bodies[spec.name])[0]
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
                loaded=lambda name=name: bool(self.carried_by(name, kinds=("ducky",))),
                loop=bot.route.loop,
            )
        self.emulator: Any = None
        self.model: Any = None
        #: Indices of link boxes that move rigidly with the tool (the end effector).
        self.tool_boxes: frozenset[int] = frozenset()
        self.arm: ArmView | None = None
        self.held: str | None = None
        self._held_rel: np.ndarray | None = None
        self._last_gripper: float | None = None
        self._grip_mode = "suction"
        self.collisions = CollisionMonitor(scene.physics.collision_tolerance_mm)
        self._contact_inputs_checked: bytes | None = None
        self._slip_rng = np.random.default_rng(self._seq.spawn(2)[1])
        self._last_joints: np.ndarray | None = None
        self.events: list[WorldEvent] = []
        #: Called with every event as it happens (the run log listens here).
        self.listeners: list[Callable[[WorldEvent], None]] = []
        #: Called with the reason when a collision halts the arm (``halt_on_collision``).
        self.on_halt: Callable[[str], None] | None = None

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
            self._tool_physics(now)
            self._fall(dt, now)
            self._check_collisions(now)
            self.time = now
            self.version += 1

    def _missed_steps(self, dt: float, now: float) -> None:
        """Random slips of a loaded stepper (``world.faults.missed_steps.rate_per_s``)."""
        slips = self.scene.slips
        arm = self.arm
        if slips is None or arm is None or dt <= 0:
            return
        last = self._last_joints
        moving = (
            last is not None
            # equal lists are close; the list test spares np.allclose on a resting arm
            and last.tolist() != arm.joints.tolist()
            and not np.allclose(arm.joints, last)
        )
        self._last_joints = arm.joints.copy()
        if not (moving or self.held is not None):
            return
        if self._slip_rng.random() >= 1.0 - math.exp(-slips.rate * dt):
            return
        joints = slips.joints or tuple(range(len(arm.joints)))
        joint = int(joints[int(self._slip_rng.integers(len(joints)))])
        amount = float(self._slip_rng.uniform(-slips.max_amount, slips.max_amount))
        self.emulator.inject("missed_steps", joint=joint, amount=amount)
        self._event(now, "missed_steps", {"joint": joint, "amount": round(amount, 4)})

    def _tool_physics(self, now: float) -> None:
        arm = self.arm
        if arm is None:
            return
        tip = arm.tool_pose[:3, 3]
        if self.held is not None:
            body = self.bodies[self.held]
            assert self._held_rel is not None
            body.pose = arm.tool_pose @ self._held_rel
            if not self._still_holding(arm, body):
                self._release(now)
        elif arm.suction:
            target = self._suction_target(tip)
            if target is not None:
                self._grab(target, arm, now, "suction")
        elif arm.gripper is not None:
            target = self._gripper_target(arm)
            if target is not None:
                self._grab(target, arm, now, "gripper")
        self._last_gripper = arm.gripper

    def _opening_mm(self, arm: ArmView) -> float | None:
        if arm.gripper is None:
            return None
        return float(arm.gripper) * self.physics.gripper_mm_per_unit

    def _still_holding(self, arm: ArmView, body: Body) -> bool:
        if self._grip_mode == "suction":
            return arm.suction
        opening = self._opening_mm(arm)
        return opening is not None and opening <= min(body.size[:2]) + 1.0

    def _suction_target(self, tip: np.ndarray) -> Body | None:
        """The highest movable body whose top face is within the pick tolerance of the cup."""
        tol = self.physics.pick_tolerance_mm
        best = None
        for body in self.bodies.values():
            if body.kind not in MOVABLE or body.falling or body.held:
                continue
            if abs(tip[2] - body.top) > tol:
                continue
            if not point_in_polygon(tip[:2], body.footprint()):
                continue
            if best is None or body.top > best.top:
                best = body
        return best

    def _gripper_target(self, arm: ArmView) -> Body | None:
        """A movable body between the jaws when they close on it."""
        opening = self._opening_mm(arm)
        if opening is None:
            return None
        was = (
            None
            if self._last_gripper is None
            else self._last_gripper * self.physics.gripper_mm_per_unit
        )
        tip = arm.tool_pose[:3, 3]
        for body in self.bodies.values():
            if body.kind not in MOVABLE or body.falling or body.held:
                continue
            width = float(min(body.size[:2]))
            closing_on_it = opening <= width + 1.0 and (was is None or was > width + 1.0)
            # The jaws reach a little below the tool centre: a grip from just above the top holds.
            inside = body.bottom - 1.0 <= tip[2] <= body.top + self.physics.pick_tolerance_mm
            centred = np.linalg.norm(tip[:2] - body.pose[:2, 3]) <= 0.25 * width
            if closing_on_it and inside and centred:
                return body
        return None

    def _grab(self, body: Body, arm: ArmView, now: float, mode: str) -> None:
        self.held = body.name
        self._grip_mode = mode
        body.held, body.falling, body.vz, body.support = True, False, 0.0, None
        self._held_rel = np.linalg.inv(arm.tool_pose) @ body.pose
        for other in self.bodies.values():
            if other.support == body.name:
                other.support, other.falling, other.vz = None, True, 0.0
                other.fall_from = other.bottom
        self._event(now, "pick", {"object": body.name, "by": mode})

    def _release(self, now: float) -> None:
        assert self.held is not None
        body = self.bodies[self.held]
        # A released object hangs level: keep only its heading and position.
        body.pose = pose(rot_z(body.yaw), body.pose[:3, 3])
        body.held, body.falling, body.vz = False, True, 0.0
        body.fall_from = body.bottom
        self.held, self._held_rel = None, None
        self._event(now, "release", {"object": body.name, "at": body.pose[:3, 3].round(2).tolist()})

    def _support_below(self, body: Body) -> tuple[str, float]:
        """The surface under the body's centre: (name, height mm); the table at least.

        A surface up to the collision tolerance above the body's bottom still
        counts (it is raised onto it): contacts that shallow are not collisions,
        so a body let go that shallowly inside another rests on it.
        """
        centre = body.pose[:2, 3]
        slack = self.physics.collision_tolerance_mm
        if not point_in_polygon(centre, self.table.polygon()):
            return "floor", self.table.height - FLOOR_DROP
        best_name, best_z = "table", self.table.height
        for other in self.bodies.values():
            if other is body or other.held or other.kind == "spot" or other.falling:
                continue
            if other.support == body.name:
                continue
            if other.kind == "bin":
                inner = other.footprint(shrink=other.spec.wall)
                z = other.bottom + other.spec.wall if point_in_polygon(centre, inner) else other.top
            else:
                z = other.top
            if (
                z > best_z
                and z <= body.bottom + slack + 1e-6
                and point_in_polygon(centre, other.footprint())
            ):
                best_name, best_z = other.name, z
        return best_name, best_z

    def _fall(self, dt: float, now: float) -> None:
        for body in self.bodies.values():
            if not body.falling:
                continue
            name, z = self._support_below(body)
            body.vz += GRAVITY * dt
            new_bottom = body.bottom - body.vz * dt
            if new_bottom <= z:
                body.pose[2, 3] = z
                body.falling, body.vz, body.support = False, 0.0, name
                body.off_table = name == "floor"
                fall = round(body.fall_from - z, 2)
                self._event(now, "land", {"object": body.name, "on": name, "fall_mm": fall})
                if body.off_table or (fall > DROP_MM and self.in_bin(body) is None):
                    self._event(now, "drop", {"object": body.name, "on": name, "fall_mm": fall})
            else:
                body.pose[2, 3] = new_bottom

    def start_overlaps(self) -> list[tuple[str, str]]:
        """(link, body) pairs that interpenetrate now: a world placing bodies inside the arm."""
        with self.lock:
            if self.arm is None:
                return []
            links, others = self._solids()
            probe = CollisionMonitor(self.collisions.tolerance)
            return [(hit.link, hit.other) for hit in probe.update(self.time, links, others)]

    def _solids(self) -> tuple[list[SolidBox], list[SolidBox]]:
        """The arm's boxes (and what it holds), and the bodies they could hit."""
        arm = self.arm
        assert arm is not None
        links = [
            SolidBox(n, p, s)
            for n, p, s in zip(arm.box_names, arm.box_poses, arm.box_sizes, strict=True)
        ]
        if self.held is not None:
            held = self.bodies[self.held]
            links += [SolidBox(f"held {held.name}", held.center_pose(), held.size)]
        tip = arm.tool_pose[:3, 3]
        tol = self.physics.pick_tolerance_mm
        # The tool centre (suction cup, gripper tips) is the lowest point of an end
        # effector: a body whose top is below it is touched at most, never hit, even
        # where a model's link box reaches lower than the tool centre.
        others = [
            solid
            for b in self.bodies.values()
            if not b.held and b.top > tip[2] + tol
            for solid in b.solids()
        ]
        return links, others

    def _held_contacts(self, checked: set[str]) -> dict[tuple[str, str], float]:
        """Depths (mm) of the held body in the bodies :meth:`_solids` leaves out.

        The tool centre's exemption is the end effector's: what it holds hangs
        below it and is pressed into a body under the tool as any link would be.
        """
        if self.held is None:
            return {}
        held = self.bodies[self.held]
        name = f"held {held.name}"
        centre = held.center_pose()
        out: dict[tuple[str, str], float] = {}
        for body in self.bodies.values():
            if body.held or body.name in checked:
                continue
            for solid in body.solids():
                depth = obb_penetration(centre, held.size, solid.pose, solid.size)
                out[(name, solid.name)] = max(out.get((name, solid.name), 0.0), float(depth))
        return out

    def _contact_inputs(self) -> bytes:
        """Everything a collision check reads: the arm's boxes and tool, what it holds, the bodies."""
        arm = self.arm
        assert arm is not None
        parts = [arm.box_poses.tobytes(), arm.tool_pose.tobytes(), str(self.held).encode()]
        for body in self.bodies.values():
            parts += [body.pose.tobytes(), body.size.tobytes(), b"H" if body.held else b"-"]
        return b"".join(parts)

    def _check_collisions(self, now: float) -> None:
        arm = self.arm
        if arm is None:
            return
        inputs = self._contact_inputs()
        if inputs == self._contact_inputs_checked:
            # Nothing moved since the last check: the same contacts, none of them new.
            return
        self._contact_inputs_checked = inputs
        links, others = self._solids()
        extra = {("tool", "table"): float(self.table.height - arm.tool_pose[2, 3])}
        extra.update(self._held_contacts({solid.name for solid in others}))
        fresh = self.collisions.update(now, links, others, extra)
        for hit in fresh:
            self._event(now, "collision", dataclasses.asdict(hit))
            if self.physics.halt_on_collision and self.emulator is not None:
                reason = f"collision: {hit.link} hit {hit.other} ({hit.depth_mm:.1f} mm deep)"
                self.emulator.halt(reason)
                if self.on_halt is not None:
                    self.on_halt(reason)

    def _event(self, now: float, kind: str, detail: dict[str, Any]) -> None:
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
                self._fall(SETTLE_STEP_S, self.time + waited)

    # -- queries --------------------------------------------------------------------

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
        """Ground truth for scoring a run (never for deciding): bins, Duckybots, collisions."""
        with self.lock:
            objects = {}
            in_bin = []
            for name, b in sorted(self.bodies.items()):
                where = self.in_bin(b)
                if where is not None:
                    in_bin.append(name)
                objects[name] = {
                    "kind": b.kind,
                    "position_mm": b.pose[:3, 3].round(2).tolist(),
                    "yaw_deg": round(math.degrees(b.yaw), 2),
                    "on": b.support,
                    "held": b.held,
                    "in_bin": where,
                    "marker": None if b.marker is None else b.marker.id,
                }
            on_bots = {
                name: sorted(c.name for c in self.carried_by(name, kinds=("ducky",)))
                for name in self.duckybots
            }
            trash = [n for n, b in self.bodies.items() if b.kind == "trash"]
            return {
                "time_s": round(self.time, 6),
                "objects": objects,
                "in_bin": in_bin,
                "trash_total": len(trash),
                "trash_in_bin": sum(1 for n in trash if n in in_bin),
                "duckies_on_duckybots": on_bots,
                "ducky_on_duckybot": any(on_bots.values()),
                "held": self.held,
                "fell_off_table": sorted(n for n, b in self.bodies.items() if b.off_table),
                "collision_count": len(self.collisions.log),
                "collisions": [dataclasses.asdict(c) for c in self.collisions.log],
                "duckybots": {
                    name: {
                        "pose": [
                            round(bot.state.x, 2),
                            round(bot.state.y, 2),
                            round(math.degrees(bot.state.theta), 2),
                        ],
                        "phase": bot.phase,
                        "max_tracking_error_mm": round(bot.max_tracking_error, 3),
                    }
                    for name, bot in self.duckybots.items()
                },
                "missed_steps": [
                    e.detail | {"time": round(e.time, 6)}
                    for e in self.events
                    if e.kind == "missed_steps"
                ],
                "events": len(self.events),
            }


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
