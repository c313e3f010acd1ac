"""What a behaviour is handed: the rig (arm, camera, tracker, planner, tags, places).

These are the interfaces plugins implement. A skill programs against them and
never imports a plugin module, so the same tree drives the simulation and the
bench. Units: millimetres and degrees; times in seconds on the run's clock.
"""

from __future__ import annotations

import contextlib
import enum
import math
import threading
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np

from armtree.errors import HardwareFault, PlanningError, Unreachable
from armtree.maths.motion.kinematics import KinematicModel

from .clock import Clock
from .views import ProfileView

# ---------------------------------------------------------------------------
# Motion
# ---------------------------------------------------------------------------


class MotionStatus(enum.Enum):
    """Where a commanded motion is: queued, under way, finished, failed or stopped."""

    PENDING = "pending"
    RUNNING = "running"
    DONE = "done"
    FAILED = "failed"
    STOPPED = "stopped"


class MotionHandle:
    """Progress of one command to an arm, updated by the driver's thread.

    A behaviour polls it from ``update()``; it never blocks. :attr:`done` is True
    once the command ended in any way, DONE, FAILED or STOPPED alike: a failed
    motion is ``done`` too, so test :attr:`status` for ``MotionStatus.DONE`` to know
    it succeeded. ``error`` holds the :class:`HardwareFault` or refusal (an
    :class:`~armtree.errors.Unreachable` for a target refused before a byte was
    sent) that ended a FAILED motion.
    """

    def __init__(self, description: str, target: np.ndarray | None = None) -> None:
        self.description = description
        self.target = target
        self._status = MotionStatus.PENDING
        self._progress = 0.0
        self.error: Exception | None = None
        self._lock = threading.Lock()
        self._finished = threading.Event()

    @property
    def status(self) -> MotionStatus:
        """The current :class:`MotionStatus`."""
        with self._lock:
            return self._status

    @property
    def progress(self) -> float:
        """Fraction done, 0 to 1."""
        with self._lock:
            return self._progress

    @property
    def done(self) -> bool:
        """True once the motion ended in any way: DONE, FAILED or STOPPED (not success)."""
        return self._finished.is_set()

    def update(
        self, status: MotionStatus, progress: float | None = None, error: Exception | None = None
    ) -> None:
        """Driver side: record new status; terminal statuses are final."""
        with self._lock:
            if self._finished.is_set():
                return
            self._status = status
            if progress is not None:
                self._progress = min(1.0, max(0.0, progress))
            if error is not None:
                self.error = error
            if status in (MotionStatus.DONE, MotionStatus.FAILED, MotionStatus.STOPPED):
                if status is MotionStatus.DONE:
                    self._progress = 1.0
                self._finished.set()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until finished (for scripts and tests, never inside a tick)."""
        return self._finished.wait(timeout)

    def __repr__(self) -> str:
        return f"<MotionHandle {self.description} {self.status.value} {self.progress:.0%}>"


@dataclass
class ToolState:
    """The end effector as last reported: suction on/off, gripper opening (deg or mm)."""

    suction: bool = False
    gripper: float | None = None


class ArmDriver(ABC):
    """A connected arm. Serial I/O runs on the driver's own thread.

    Every method returns at once. Targets are checked against the model's
    limits and reachability before a byte is sent; a refused target gives a
    FAILED handle whose ``error`` is an :class:`~armtree.errors.Unreachable`.
    """

    #: The arm's kinematic model.
    model: KinematicModel
    #: The port or device this driver talks to, for messages.
    device: str = ""
    #: False for an arm whose firmware only takes set points (hobby servos on an
    #: SSC-32): the host times the motion, so a planner's whole path goes to
    #: :meth:`follow_path` as one trajectory instead of one :meth:`move_joints` per waypoint.
    interpolates: bool = True
    #: What the arm holds things with, for :class:`ArmTool`: ``"suction"`` (the pump,
    #: :meth:`set_suction`) or ``"gripper"`` (:meth:`set_gripper` to :attr:`grip_closed`
    #: and :attr:`grip_open`).
    tool_kind: str = "suction"
    #: The gripper openings (degrees of its servo, or mm) that hold and that let go.
    grip_closed: float = 0.0
    grip_open: float = 90.0

    @abstractmethod
    def connect(self) -> None:
        """Open the link and wait for the arm to report; raise :class:`HardwareFault`."""

    @abstractmethod
    def close(self) -> None:
        """Stop and release the port. Safe to call twice."""

    @abstractmethod
    def joints(self) -> np.ndarray:
        """Joint positions as last reported by the arm, degrees / mm."""

    @abstractmethod
    def move_joints(self, q: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Move to joint target ``q`` (degrees / mm) at ``speed`` (fraction of maximum)."""

    def follow_path(self, waypoints: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Move through joint ``waypoints`` ``(N, n)`` (degrees / mm) without stopping between them.

        Arms that do not interpolate (:attr:`interpolates` False) implement it:
        the path is timed within the joints' speed and acceleration limits and
        validated along the way before a byte is sent. Others refuse it; send
        their waypoints to :meth:`move_joints` one after another.
        """
        handle = MotionHandle("follow path")
        handle.update(
            MotionStatus.FAILED,
            error=Unreachable(
                f"{self.model.name} interpolates its own moves: send waypoints with move_joints"
            ),
        )
        return handle

    @abstractmethod
    def move_to(self, xyz: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Move the tool centre to ``xyz`` (mm, base frame)."""

    @abstractmethod
    def set_suction(self, on: bool) -> MotionHandle:
        """Switch the suction pump; DONE when the arm has acknowledged it.

        Skills grip through ``rig.tool`` (:class:`ArmTool` calls this or
        :meth:`set_gripper` as :attr:`tool_kind` says), which works on every rig."""

    @abstractmethod
    def stop(self) -> None:
        """Stop motion at once (decelerating as the firmware does); keep the tool state."""

    def busy(self) -> bool:
        """True while a command sent to the arm is still under way (a paused run waits for it)."""
        return False

    def request_stop(self) -> None:
        """Ask for :meth:`stop` from another thread than the run's; returns at once.

        The tick watchdog calls it while the run's thread is stuck. The default
        runs :meth:`stop` on a short-lived thread; drivers with an I/O thread
        stop from there.
        """
        threading.Thread(target=self.stop, name=f"stop {self.device}", daemon=True).start()

    def set_gripper(self, opening: float) -> MotionHandle:
        """Set the gripper opening (degrees of the gripper servo, or mm)."""
        handle = MotionHandle("gripper")
        handle.update(
            MotionStatus.FAILED, error=HardwareFault("this arm has no gripper", self.device)
        )
        return handle

    def home(self) -> MotionHandle:
        """Go to the model's home configuration (arms with end stops home on them)."""
        return self.move_joints(self.model.home)

    def pose(self) -> np.ndarray:
        """Tool pose from the reported joints, 4x4, mm."""
        return self.model.fk(self.joints())

    @property
    def tool(self) -> ToolState:
        """The tool as last reported."""
        return ToolState()

    @property
    def fault(self) -> HardwareFault | None:
        """The fault that stopped the link, if any."""
        return None

    def suspended_s(self, since: float) -> float:
        """Wall seconds the process was suspended (SIGSTOP, Ctrl-Z, a laptop asleep) after
        clock time ``since`` (s), as far as this driver noticed: a motion's allowance does
        not run while nobody watched it. 0.0 for a driver that does not watch for pauses."""
        return 0.0


# ---------------------------------------------------------------------------
# The tool
# ---------------------------------------------------------------------------


class Tool(ABC):
    """What holds things at the end of the arm: a suction cup, a gripper, a plugin's own.

    A skill grips through ``rig.tool`` whatever the rig has, so one tree runs on
    every rig: :meth:`grip` and :meth:`release` return a :class:`MotionHandle`
    to poll from ``update()`` (DONE when the tool reports it, FAILED with the
    reason otherwise), and :attr:`holding` says whether the tool reports that it
    grips (a pump on, a gripper nearer closed than open). Whether an object is in
    it is for the camera to check. The built-in arms drive their own tool
    (:class:`ArmTool`); a plugin with a separate one (a gripper on its own servo
    controller) subclasses this and sets ``rig.tool`` in ``armtree_rig_ready``.
    """

    #: ``"suction"``, ``"gripper"``, or the plugin's own word for its tool.
    kind: str = ""

    @abstractmethod
    def grip(self) -> MotionHandle:
        """Take hold (pump on, gripper closed); never blocks."""

    @abstractmethod
    def release(self) -> MotionHandle:
        """Let go (pump off, gripper open); never blocks."""

    @property
    @abstractmethod
    def holding(self) -> bool:
        """True when the tool reports that it grips."""


class ArmTool(Tool):
    """The tool an arm's driver drives: its pump (``tool_kind`` ``"suction"``) or its
    gripper, closed to ``grip_closed`` and opened to ``grip_open``."""

    def __init__(self, arm: ArmDriver) -> None:
        self.arm = arm

    @property
    def kind(self) -> str:  # type: ignore[override]
        """The driver's ``tool_kind``."""
        return str(getattr(self.arm, "tool_kind", "suction"))

    def grip(self) -> MotionHandle:
        """Pump on, or the gripper to ``grip_closed``."""
        if self.kind == "gripper":
            return self.arm.set_gripper(float(getattr(self.arm, "grip_closed", 0.0)))
        return self.arm.set_suction(True)

    def release(self) -> MotionHandle:
        """Pump off, or the gripper to ``grip_open``."""
        if self.kind == "gripper":
            return self.arm.set_gripper(float(getattr(self.arm, "grip_open", 90.0)))
        return self.arm.set_suction(False)

    @property
    def holding(self) -> bool:
        """Suction on, or a gripper reported nearer closed than open.

        A tool state's ``gripper`` field alone is no sign of a gripper: the Dobot
        V1.0 reports a gripper angle in every status frame whatever is mounted.
        """
        state = self.arm.tool
        if self.kind == "gripper" and state.gripper is not None:
            closed = float(getattr(self.arm, "grip_closed", 0.0))
            opened = float(getattr(self.arm, "grip_open", 90.0))
            return abs(state.gripper - closed) < abs(state.gripper - opened)
        return bool(state.suction)


# ---------------------------------------------------------------------------
# Vision
# ---------------------------------------------------------------------------


@dataclass
class Frame:
    """One camera image with what is needed to measure in it.

    ``image`` is ``HxWx3`` BGR or ``HxW`` grey uint8; ``camera_matrix`` is 3x3 in
    pixels; ``distortion`` holds OpenCV's (k1, k2, p1, p2, k3); ``timestamp`` is
    seconds on the run's clock. An image of an uncalibrated camera (``armtree
    detect`` on a file without ``--intrinsics``) has neither: trackers find markers
    in it but measure no pose.
    """

    image: np.ndarray
    timestamp: float
    camera_matrix: np.ndarray | None
    distortion: np.ndarray | None
    index: int = 0


@dataclass
class Detection:
    """A marker found in a frame.

    ``corners`` is ``(4, 2)`` pixels in OpenCV's order (top-left, top-right,
    bottom-right, bottom-left of the marker as printed). ``rvec`` (Rodrigues,
    radians) and ``tvec`` (mm) give the marker's pose in the camera frame when
    its size is known. ``quality`` is the reprojection error in pixels (aruco)
    or the number of bit errors corrected (hamming).
    """

    id: int
    corners: np.ndarray
    family: str = "aruco"
    rvec: np.ndarray | None = None
    tvec: np.ndarray | None = None
    quality: float = 0.0
    role: str = "unknown"
    size_mm: float | None = None
    ambiguous: bool = False


class Camera(ABC):
    """A source of frames. Capture runs on its own thread; :meth:`read` never blocks."""

    #: ``"eye_in_hand"`` (on the tool) or ``"eye_to_hand"`` (fixed).
    mount: str = "eye_to_hand"
    #: Camera pose: in the tool frame (eye-in-hand) or base frame (eye-to-hand), 4x4 mm.
    extrinsics: np.ndarray = np.eye(4)
    #: Frames a second, when known.
    fps: float | None = None

    def stamp_due(self, now: float) -> float:
        """The stamp (s, run clock) of the newest frame at run time ``now``: the last
        multiple of the period when ``fps`` is known (exact for the simulation's camera,
        a guess for a real one), else ``now``."""
        if not self.fps or self.fps <= 0:
            return now
        return frame_index(now, self.fps) / self.fps

    @abstractmethod
    def start(self) -> None:
        """Open the device; raise :class:`HardwareFault` naming it if it cannot."""

    @abstractmethod
    def read(self) -> Frame | None:
        """The newest frame, or None if none arrived since the last call."""

    def close(self) -> None:  # noqa: B027 - optional for cameras with nothing to release
        """Release the device."""


def frame_index(now: float, fps: float) -> int:
    """The number of the newest frame at run time ``now`` (s) of a camera taking ``fps``
    frames a second from time 0."""
    return int(math.floor(now * fps + 1e-9))


class Tracker(ABC):
    """Finds markers in a frame.

    ``marker_family`` names the markers it reads (``"hamming"``, or an ArUco
    dictionary such as ``"4x4_50"`` or ``"apriltag_36h11"``): the rig gives it
    the profile's tag ids for that family (``tags: ROLE: family_ids:``).
    ``unread`` is how many marker-like shapes of the last :meth:`detect`'s frame
    (a dark square border around light and dark cells, apart from every marker
    reported) decoded as nothing in that family: markers of another family, or
    ones too blurred to read. Skills word a failed search with it.
    """

    #: The marker family read; None when it has no name tags could use.
    marker_family: str | None = None
    #: Marker-like shapes in the last frame that decoded as nothing in the family.
    unread: int = 0

    def start(self) -> None:  # noqa: B027 - optional: trackers with nothing to prepare
        """Prepare for the first frame (load or compile what detection needs); the rig calls it."""

    @abstractmethod
    def detect(self, frame: Frame) -> list[Detection]:
        """Every marker in ``frame``, one detection per physical marker."""


# ---------------------------------------------------------------------------
# Planning
# ---------------------------------------------------------------------------


class Planner(ABC):
    """Finds a collision-free joint path for the rig's arm (:attr:`model`)."""

    model: KinematicModel
    #: Told ``report(event, message, **data)`` what the run log should record (a start
    #: stepped out of a shallow contact); the run connects it, None records nothing.
    report: Callable[..., None] | None = None

    @abstractmethod
    def plan(self, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """Waypoints ``(N, n)`` in degrees / mm from ``start`` to ``goal`` joints.

        Raises :class:`~armtree.errors.PlanningError` with a reason when there is none.
        """

    def plan_to(self, start: np.ndarray, xyz: np.ndarray) -> np.ndarray:
        """Waypoints to a Cartesian tool position (mm).

        Inverse-kinematics solutions are tried nearest-first, as the UR5 report
        (Pozzani 2023) sorts them; the last refusal is raised if none has a path.
        """
        start = np.asarray(start, dtype=float)
        sols = self.model.ik_all(np.asarray(xyz, dtype=float))
        sols = sols[np.all(np.isfinite(sols), axis=-1)]
        if len(sols) == 0:
            raise Unreachable(f"{self.model.name}: {np.round(xyz, 2).tolist()} mm is unreachable")
        last: PlanningError | None = None
        for q in sols[np.argsort(np.linalg.norm(sols - start, axis=-1))]:
            try:
                return self.plan(start, q)
            except PlanningError as exc:
                last = exc
        assert last is not None
        raise last


# ---------------------------------------------------------------------------
# The rig
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class TagSpec:
    """A marker role from the profile's ``tags:`` section.

    ``ids`` are the role's markers; ``family_ids`` the same markers in marker
    families that number them otherwise (``{"hamming": (69937,)}``), keyed by
    the family name a tracker gives as :attr:`Tracker.marker_family`.
    """

    role: str
    ids: tuple[int, ...]
    size_mm: float
    family_ids: Mapping[str, tuple[int, ...]] = field(default_factory=dict, hash=False)

    def in_family(self, family: str | None) -> TagSpec:
        """This role as a tracker of marker family ``family`` reads it: ``ids`` are its ids there."""
        ids = self.family_ids.get(family, self.ids) if family else self.ids
        return TagSpec(self.role, tuple(ids), self.size_mm, self.family_ids)


def _no_interrupt(reason: str, fault: HardwareFault | None = None) -> None:
    """The interrupt of a context made without a run: nothing to halt."""


@dataclass
class RigContext:
    """What a component factory receives besides its own configuration.

    ``shared`` is scoped to one rig (for example the simulated world that the
    sim arm and sim camera both use); ``interrupt`` lets a component halt the
    tree (an e-stop, a lost link) from any thread.
    """

    profile: ProfileView | None
    clock: Clock
    seed: int = 0
    shared: dict[str, Any] = field(default_factory=dict)
    interrupt: Callable[[str, HardwareFault | None], None] = _no_interrupt
    record_dir: Any = None
    #: Called once per tick with the run's time, in order of registration (the sim's
    #: emulators then its world). On a virtual clock a stepper returns only when its
    #: component has caught up with that time, so runs are deterministic.
    steppers: list[Callable[[float], None]] = field(default_factory=list)
    #: Called when the rig closes, newest first.
    closers: list[Callable[[], None]] = field(default_factory=list)


PartT = TypeVar("PartT")


def needed(part: PartT | None, name: str) -> PartT:
    """``part`` of a rig (its arm, camera, tracker) where a skill's ``NEEDS`` made sure the
    rig has it before any step ran; a RuntimeError naming it (and the fix) if not."""
    if part is None:
        raise RuntimeError(f"this rig has no {name}: a skill that uses it lists it in NEEDS")
    return part


#: The order a rig starts its components in (:meth:`Rig.start`); they are closed in reverse.
#: The arm comes first so its link is up and it reports where it is before anything that
#: rides on it (a tool, a camera head) moves; the camera after the head that points it;
#: the tracker and planner, software, last. Closing in reverse releases the arm's link
#: last, after :meth:`Rig.stop` has already told it to stop.
START_ORDER: tuple[str, ...] = ("arm", "tool", "head", "camera", "tracker", "planner")


@dataclass
class Rig:
    """The hardware a tree runs on, built from a profile. Handed to every behaviour.

    Lifecycle (owned by the rig, driven by :func:`armtree.runtime.rig_builder.build_rig`):

    1. *built*: every component's factory has run (no device opened by the
       rig yet; an arm factory with ``port: sim`` has started its emulator,
       registered in :attr:`closers`);
    2. *started*: :meth:`start` starts the components present in
       :data:`START_ORDER` (``arm.connect()``, then ``start()`` of each other
       component that has one), after the profile has validated and the
       ``armtree_rig_ready`` hook has wired them;
    3. *closed*: :meth:`close` tells the arm to stop, closes every component
       in reverse :data:`START_ORDER` (``close()``, where it has one, also for
       one whose start failed), then runs :attr:`closers` newest first
       (emulators, the simulated world, recorders).

    A fault while starting closes what was built, in the same order, before
    it propagates; :meth:`close` never raises and is safe to call twice.
    ``tool`` is what skills grip with (a :class:`Tool`): a rig built with an arm
    gets the arm's own (:class:`ArmTool`) unless a plugin set another in
    ``armtree_rig_ready`` or the arm has none; ``head`` is a slot for a plugin's
    camera head.
    """

    profile: ProfileView
    clock: Clock
    arm: ArmDriver | None = None
    camera: Camera | None = None
    tracker: Tracker | None = None
    planner: Planner | None = None
    tool: Tool | None = None
    head: Any = None
    #: A measuring device outside the arm (:class:`armtree.api.measuring.MeasuringDevice`):
    #: the ground truth of calibrations and accuracy experiments; the simulation sets
    #: its simulated one, the calibrate and experiment commands ask the operator on
    #: hardware. Never what a skill decides by.
    reference: Any = None
    tags: dict[str, TagSpec] = field(default_factory=dict)
    places: dict[str, list[float]] = field(default_factory=dict)
    #: Per-tick hooks of components that must advance with the run (the sim).
    steppers: list[Callable[[float], None]] = field(default_factory=list)
    #: Things to close when the run ends, newest first, after the components.
    closers: list[Callable[[], None]] = field(default_factory=list)
    #: Names of the components :meth:`start` has started (or tried to), in order.
    started: list[str] = field(default_factory=list)
    #: The camera reader every behaviour of the run shares
    #: (:class:`armtree.api.skill.eye.Eye`: each frame read and its markers located once),
    #: made by :func:`armtree.api.skill.eye.eye_of` on first use. Data between behaviours
    #: goes through the blackboard, never through attributes added to the rig.
    eye: Any = None

    def __post_init__(self) -> None:
        if self.tool is None and self.arm is not None:
            self.tool = ArmTool(self.arm)

    def role_of(self, marker_id: int) -> TagSpec | None:
        """The tag spec whose ids include ``marker_id``."""
        for spec in self.tags.values():
            if marker_id in spec.ids:
                return spec
        return None

    def components(self) -> list[tuple[str, Any]]:
        """``(name, component)`` of every component present, in :data:`START_ORDER`."""
        found = ((name, getattr(self, name)) for name in START_ORDER)
        return [(name, c) for name, c in found if c is not None]

    def start(self) -> None:
        """Start every component in :data:`START_ORDER`; on any error close the rig and re-raise.

        The arm starts with ``connect()`` (raises :class:`HardwareFault` naming
        its port), the others with ``start()`` when they have one (a camera
        that does not open raises :class:`HardwareFault` naming its device).
        """
        try:
            for name, component in self.components():
                if name in self.started:
                    continue
                self.started.append(name)
                begin = component.connect if name == "arm" else getattr(component, "start", None)
                if callable(begin):
                    begin()
        except BaseException:
            self.close()
            raise

    def step(self, now: float) -> None:
        """Advance every stepping component to ``now`` (seconds); called once per tick."""
        for stepper in self.steppers:
            stepper(now)

    def stop(self) -> None:
        """Tell the arm to stop at once; never raises."""
        if self.arm is not None:
            with contextlib.suppress(Exception):  # stopping must not fail the shutdown
                self.arm.stop()

    def request_stop(self) -> None:
        """Ask the arm to stop without waiting (from a thread other than the run's)."""
        if self.arm is not None:
            with contextlib.suppress(Exception):
                self.arm.request_stop()

    def close(self) -> None:
        """Stop the arm, close the components in reverse start order, then the closers.

        Never raises; safe to call twice.
        """
        self.stop()
        for _name, component in reversed(self.components()):
            closer = getattr(component, "close", None)
            if callable(closer):
                with contextlib.suppress(Exception):  # one broken close must not keep the rest
                    closer()
        self.started.clear()
        while self.closers:
            closer = self.closers.pop()
            with contextlib.suppress(Exception):
                closer()
