"""Non-blocking steps a skill is made of: move, switch the tool, pause, look.

Each :class:`Action` is started once and then polled once per tick until it
ends; nothing here waits on I/O. Units: millimetres, degrees, seconds on the
run's clock.
"""

from __future__ import annotations

import enum
from typing import Any

import numpy as np

from armtree.api.rig import MotionHandle, MotionStatus, Rig, needed
from armtree.config.calibration import calibration_of
from armtree.errors import PlanningError, Unreachable

from .eye import Sighting, Tally, eye_of


class SkillFailure(Exception):
    """A skill cannot go on; the message becomes the behaviour's feedback."""


class State(enum.Enum):
    """Where an action is."""

    RUNNING = "running"
    DONE = "done"
    FAILED = "failed"


def fmt(xyz: Any) -> str:
    """A position as ``[x, y, z] mm`` for messages."""
    return f"{np.round(np.asarray(xyz, dtype=float), 1).tolist()} mm"


class Action:
    """One step of a skill: :meth:`start` once, :meth:`poll` every tick, :meth:`stop` if halted.

    After :meth:`poll` returns ``DONE``, :attr:`result` holds what the step produced;
    after ``FAILED``, :attr:`message` says why.
    """

    result: Any = None
    message: str = ""

    def start(self) -> None:
        """Begin the step; must return at once."""

    def poll(self) -> State:
        """Advance and report the step's state; must return at once."""
        return State.DONE

    def stop(self) -> None:
        """Halt the step (the skill was halted); must return at once."""

    def fail(self, message: str) -> State:
        """Record why the step failed and return ``FAILED``."""
        self.message = message
        return State.FAILED


class Move(Action):
    """Move the tool centre to ``xyz`` (mm, base frame), or the joints to ``joints``.

    A profile's arm correction (Durovic 2017, eq. 8; ``corrected=False`` to leave it out)
    turns ``xyz`` into the position to command. With a planner the path is planned
    (limits, reachability, collisions) and its waypoints are sent one after another; without one the arm's own target checks
    apply. A refused target fails the step with the reason; nothing is sent. A
    motion that has not ended after :data:`TIMEOUT_FACTOR` times its expected
    duration plus :data:`TIMEOUT_SLACK` seconds (a stalled or halted arm) stops
    the arm and fails the step; time the process was suspended
    (``ArmDriver.suspended_s``) is not counted.
    """

    #: Multiple of a motion's expected duration after which it has stalled.
    TIMEOUT_FACTOR = 3.0
    #: Seconds added to every motion's allowance (acceleration, serial round trips).
    TIMEOUT_SLACK = 5.0

    def __init__(
        self,
        rig: Rig,
        xyz: np.ndarray | None = None,
        *,
        joints: np.ndarray | None = None,
        speed: float = 1.0,
        label: str = "move",
        corrected: bool = True,
    ) -> None:
        if xyz is None and joints is None:
            raise ValueError(f"{label}: a Move needs a position (xyz) or joints to go to")
        self.rig = rig
        self.xyz = None if xyz is None else np.asarray(xyz, dtype=float).reshape(3)
        #: Whether the profile's arm correction (Durovic 2017, eq. 8) applies to ``xyz``.
        self.corrected = corrected
        self.joints = None if joints is None else np.asarray(joints, dtype=float)
        self.speed = speed
        self.label = label
        self._waypoints: list[np.ndarray] = []
        self._handle: MotionHandle | None = None
        self._deadline = float("inf")
        self._allowed_from = 0.0

    def describe(self) -> str:
        """What this move goes to, for messages."""
        if self.xyz is not None:
            return f"{self.label} to {fmt(self.xyz)}"
        return f"{self.label} to joints {np.round(self._joint_goal(), 1).tolist()}"

    def _joint_goal(self) -> np.ndarray:
        """The joints to go to, for a move given no position."""
        assert self.joints is not None, "__init__ refuses a move given neither xyz nor joints"
        return self.joints

    def start(self) -> None:
        arm, planner = needed(self.rig.arm, "arm"), self.rig.planner
        self.message = ""
        if self.xyz is not None and self.corrected:
            # where to send the tool so that it really arrives at xyz
            self.xyz = calibration_of(getattr(self.rig, "profile", None)).command_for(self.xyz)
            self.corrected = False
        try:
            if planner is None:
                if self.xyz is not None:
                    goal = arm.model.ik(self.xyz, near=arm.joints())
                    self._handle = arm.move_to(self.xyz, self.speed)
                else:
                    goal = self._joint_goal()
                    self._handle = arm.move_joints(goal, self.speed)
                self._allow(goal)
                return
            q0 = np.asarray(arm.joints(), dtype=float)
            if self.xyz is not None:
                path = planner.plan_to(q0, self.xyz)
            else:
                path = planner.plan(q0, self._joint_goal())
        except (Unreachable, PlanningError) as exc:
            self.message = f"{self.describe()} refused: {exc}"
            return
        waypoints = [np.asarray(w, dtype=float) for w in np.atleast_2d(path)]
        while len(waypoints) > 1 and np.allclose(waypoints[0], q0, atol=1e-6):
            waypoints.pop(0)
        if not getattr(arm, "interpolates", True):
            # firmware without interpolation: the whole path goes as one timed trajectory
            self._allow(*waypoints)
            self._handle = arm.follow_path(np.stack(waypoints), self.speed)
            return
        self._waypoints = waypoints
        self._next()

    @property
    def handle(self) -> MotionHandle | None:
        """The motion under way, if any."""
        return self._handle

    def _next(self) -> None:
        goal = self._waypoints.pop(0)
        self._allow(goal)
        self._handle = needed(self.rig.arm, "arm").move_joints(goal, self.speed)

    def _allow(self, *goals: np.ndarray) -> None:
        """Set the deadline of the motion through joints ``goals`` starting now."""
        arm = needed(self.rig.arm, "arm")
        speeds = np.array([j.max_speed for j in arm.model.joints], dtype=float)
        points = np.vstack([np.asarray(arm.joints(), dtype=float), *goals])
        delta = np.abs(np.diff(points, axis=0))
        expected = (
            float(np.sum(np.max(delta / speeds, axis=1))) / max(self.speed, 1e-3)
            if len(speeds)
            else 0.0
        )
        self._allowed_from = self.rig.clock.now()
        self._deadline = self._allowed_from + self.TIMEOUT_FACTOR * expected + self.TIMEOUT_SLACK

    def poll(self) -> State:
        if self.message:
            return State.FAILED
        handle = self._handle
        while handle is not None and handle.done:
            if handle.status is not MotionStatus.DONE:
                reason = handle.error if handle.error is not None else handle.status.value
                return self.fail(f"{self.describe()} failed: {reason}")
            if not self._waypoints:
                self._handle = None
                return State.DONE
            self._next()
            handle = self._handle
        if handle is None:
            return State.DONE
        if self.rig.clock.now() > self._deadline + self._suspended():
            self.stop()
            return self.fail(f"{self.describe()} did not finish in time: the arm stalled")
        return State.RUNNING

    def _suspended(self) -> float:
        """Wall seconds the process was suspended since this motion's allowance began."""
        suspended_s = getattr(self.rig.arm, "suspended_s", None)
        return float(suspended_s(self._allowed_from)) if callable(suspended_s) else 0.0

    def stop(self) -> None:
        self._waypoints = []
        if self._handle is not None and not self._handle.done:
            needed(self.rig.arm, "arm").stop()


class ArmHome(Action):
    """The arm's own homing (``ArmDriver.home``: end stops where it has them); done when it ends.

    A driver that reports ``homed`` False afterwards (an end stop not seen, a step
    slipped on the way) is homed again, :data:`TRIES` times in all. Each try is
    allowed :data:`TIMEOUT` seconds, after which the arm is stopped and the step fails.
    """

    #: Seconds a homing may take (a SCARA's carriage crawling to its end stop).
    TIMEOUT = 60.0
    #: Homings tried before the step fails.
    TRIES = 3

    def __init__(self, rig: Rig) -> None:
        self.rig = rig
        self.handle: MotionHandle | None = None
        self._deadline = 0.0
        self._tries = 0

    def describe(self) -> str:
        """What this step does, for messages."""
        return "home on the arm's own reference"

    def start(self) -> None:
        self._tries += 1
        self._deadline = self.rig.clock.now() + self.TIMEOUT
        self.handle = needed(self.rig.arm, "arm").home()

    def poll(self) -> State:
        assert self.handle is not None
        if self.handle.done:
            homed = getattr(self.rig.arm, "homed", True)
            if self.handle.status is MotionStatus.DONE and homed:
                return State.DONE
            if self._tries < self.TRIES:
                self.start()
                return State.RUNNING
            why = self.handle.error or self.handle.status.value
            if self.handle.status is MotionStatus.DONE:
                why = "the arm did not report homed"
            return self.fail(f"homing failed after {self._tries} tries: {why}")
        if self.rig.clock.now() > self._deadline:
            self.stop()
            return self.fail(f"homing did not finish in {self.TIMEOUT:g} s")
        return State.RUNNING

    def stop(self) -> None:
        if self.handle is not None and not self.handle.done:
            needed(self.rig.arm, "arm").stop()


class Grip(Action):
    """Take hold (``on``) or let go with the rig's tool (``rig.tool``, whatever it is:
    a suction cup, a gripper, a plugin's); done when the tool reports it."""

    def __init__(self, rig: Rig, on: bool) -> None:
        self.rig = rig
        self.on = on
        self._handle: MotionHandle | None = None

    def describe(self) -> str:
        """``grip`` or ``release``, for the skill's feedback."""
        return "grip" if self.on else "release"

    def start(self) -> None:
        tool = self.rig.tool
        if tool is not None:
            self._handle = tool.grip() if self.on else tool.release()

    def poll(self) -> State:
        word = "grip" if self.on else "release"
        if self._handle is None:
            return self.fail(f"{word} failed: this rig has no tool")
        if not self._handle.done:
            return State.RUNNING
        if self._handle.status is not MotionStatus.DONE:
            return self.fail(f"{word} failed: {self._handle.error or self._handle.status.value}")
        return State.DONE


class Pause(Action):
    """Let ``seconds`` pass on the run's clock (a pump settling, a camera catching up)."""

    def __init__(self, clock: Any, seconds: float) -> None:
        self.clock = clock
        self.seconds = seconds
        self._until = 0.0

    def start(self) -> None:
        self._until = self.clock.now() + self.seconds

    def poll(self) -> State:
        return State.DONE if self.clock.now() >= self._until - 1e-9 else State.RUNNING


class Look(Action):
    """Read fresh camera frames while the arm is still and locate every marker in them.

    Frames stamped before the step started (plus ``settle`` seconds) are not read,
    so nothing is measured from a moving camera and no time goes to frames left
    unused. Up to ``frames`` fresh frames are read, stopping early once a marker
    of ``want`` (a role) is seen. The result is
    a list of :class:`Sighting`, newest per marker id, or with ``average`` each
    marker's position averaged over the frames that saw it. No frame within
    ``timeout`` seconds fails the step. Each frame read is added to ``tally``
    (a search's :class:`Tally`) when one is given.
    """

    def __init__(
        self,
        rig: Rig,
        clock: Any,
        want: str | None = None,
        frames: int = 3,
        settle: float = 0.0,
        timeout: float = 2.0,
        average: bool = False,
        tally: Tally | None = None,
    ) -> None:
        self.rig = rig
        self.clock = clock
        self.want = want
        self.tally = tally
        self.frames = max(1, frames)
        self.settle = settle
        self.timeout = timeout
        self.average = average
        self._all: dict[int, list[np.ndarray]] = {}
        self._seen: dict[int, Sighting] = {}
        self._count = 0
        self._t0 = 0.0
        self._used = -1

    def start(self) -> None:
        self._t0 = self.clock.now() + self.settle
        self._seen = {}
        self._all = {}
        self._count = 0
        self._used = -1
        self.result = []

    def poll(self) -> State:
        rig = self.rig
        if rig.camera is None or rig.tracker is None:
            return self.fail("this rig has no camera and tracker to look with")
        if not self._settled():
            # A frame read now would be skipped, and reading it costs a marker search
            # (and in the simulation a render).
            return State.RUNNING
        view = eye_of(rig).newest()
        if view is not None and view.timestamp >= self._t0 - 1e-9 and view.index != self._used:
            self._used = view.index
            self._count += 1
            for sighting in view.sightings:
                self._seen[sighting.id] = sighting
                self._all.setdefault(sighting.id, []).append(sighting.position)
            self.result = [self._averaged(s) for s in self._seen.values()]
            if self.tally is not None:
                in_frame = any(s.role == self.want for s in view.sightings)
                self.tally.add(view, rig.tracker, in_frame)
            wanted = self.want is None or any(s.role == self.want for s in self.result)
            if self._count >= self.frames or (self.want is not None and wanted):
                return State.DONE
        elif self.clock.now() > self._t0 + self.timeout:
            return self.fail(f"the camera gave no frame for {self.timeout:g} s")
        return State.RUNNING

    def _settled(self) -> bool:
        """True once the camera's newest frame is stamped at or after the settle time."""
        return needed(self.rig.camera, "camera").stamp_due(self.clock.now()) >= self._t0 - 1e-9

    def _averaged(self, sighting: Sighting) -> Sighting:
        positions = self._all[sighting.id]
        if not self.average or len(positions) < 2:
            return sighting
        pose = sighting.pose.copy()
        pose[:3, 3] = np.mean(positions, axis=0)
        return Sighting(sighting.role, sighting.id, pose, sighting.detection, sighting.timestamp)
