"""Dobot Magician driver: request/reply over 0xAA 0xAA frames on its own serial thread.

Follows the official DLL's flow ([DLL CDobotCommunicator.cpp]): one request
outstanding at a time, the reply matched by its id, a request resent when its
reply does not come. Queued commands (moves, suction, gripper, wait, home)
return a queue index; a motion is DONE when GetQueuedCmdCurrentIndex reaches
it, judged from the arm's own reports (Showers 2016, second safeguard). Every
target is checked against the model before a byte is sent (first safeguard)
and a duplicate of the last command is not re-sent (third safeguard).
Units: mm and degrees.
"""

from __future__ import annotations

import collections
import math
import struct
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from armtree.api.rig import MotionHandle, MotionStatus, ToolState
from armtree.errors import HardwareFault, Unreachable
from armtree.plugins.arms.common.plausibility import StatusGuard
from armtree.plugins.arms.common.serial_driver import SerialArmDriver

from . import protocol as P
from .kinematics import MagicianModel
from .paths import PathPlanner


@dataclass
class _Request:
    frame: bytes
    id: int
    on_reply: Callable[[P.Frame], None] | None = None
    sent_at: float = -math.inf
    tries: int = 0
    #: Called instead of a resend when resending could run the command twice.
    on_lost: Callable[[], None] | None = None


@dataclass
class _Pending:
    """A queued command waiting for the arm's current index to reach it."""

    handle: MotionHandle
    index: int | None = None
    start: np.ndarray | None = None
    goal: np.ndarray | None = None
    extra: list[Callable[[], None]] = field(default_factory=list)


class MagicianDriver(SerialArmDriver):
    """A Dobot Magician on a serial port (115200 8N1), real or emulated.

    ``poll_period`` (s, run clock) is how often the pose and the queue index are
    read; ``reply_timeout`` (s) how long a reply may take before the request is
    resent, ``retries`` times, after which the link counts as lost.
    """

    protocol = "Dobot Magician frames (0xAA 0xAA)"

    def __init__(
        self,
        model: MagicianModel,
        port: str,
        *,
        poll_period: float = 0.02,
        reply_timeout: float = 0.3,
        retries: int = 3,
        **options,
    ) -> None:
        options.setdefault("baud", 115200)
        super().__init__(model, port, **options)
        self.model: MagicianModel = model
        #: Doubts the joint angles the arm reports (finite, limits, speed).
        self.guard = StatusGuard(model)
        self.poll_period = poll_period
        self.reply_timeout = reply_timeout
        self.retries = retries
        self._parser = P.FrameParser()
        self._lock = threading.RLock()
        self._requests: collections.deque[_Request] = collections.deque()
        self._outstanding: _Request | None = None
        self._pending: list[_Pending] = []
        self._joints: np.ndarray | None = None
        self._current_index = 0
        self._next_poll = -math.inf
        self._tool = ToolState()
        self._last_handle: MotionHandle | None = None
        self._ratio_sent: float | None = None
        #: The firmware's path planner with the PTP parameters this driver has set.
        self._paths = PathPlanner(model)
        #: Free slots in the arm's command queue, as last read (GetQueuedCmdLeftSpace).
        self.left_space: int | None = None
        #: Wall time (``time.perf_counter``) of the newest joint report, for latency figures.
        self.status_wall = 0.0

    # ------------------------------------------------------------------ serial hooks

    def on_open(self) -> None:
        """Start the queue afresh and read the pose (the handshake)."""
        with self._lock:
            self._requests.clear()
            self._outstanding = None
            self._joints = None
            self._ratio_sent = None
        self._request(P.Cmd.QUEUE_CLEAR, 0x01)
        self._request(P.Cmd.QUEUE_START, 0x01)
        self._request(P.Cmd.GET_POSE, 0x00, on_reply=self._on_pose)

    def handshake_done(self) -> bool:
        """True once a pose has been read."""
        return self._joints is not None

    def on_data(self, data: bytes) -> None:
        """Match replies to the outstanding request (I/O thread)."""
        for frame in self._parser.feed(data):
            with self._lock:
                req = self._outstanding
                if req is None or frame.id != req.id:
                    continue  # a late reply to a request already given up on, or to a stop
                self._outstanding = None
            self.mark_alive()
            if req.on_reply is not None:
                req.on_reply(frame)
        self._send_next()

    def on_time(self, now: float) -> None:
        """Poll the pose and queue index; resend a request whose reply is overdue."""
        resend = None
        fail = False
        with self._lock:
            req = self._outstanding
            if req is not None and not math.isfinite(req.sent_at):
                req.sent_at = now  # sent before the run's first tick: its clock starts now
            lost = None
            if req is not None and now - req.sent_at > self.reply_timeout:
                fail = req.tries > self.retries
                resend = None if fail else req
                if resend is not None and req.on_lost is not None:
                    # the arm may have queued it and only the reply was lost
                    self._outstanding, resend, lost = None, None, req.on_lost
            if self._outstanding is None and not self._requests and now >= self._next_poll:
                self._next_poll = now + self.poll_period
                if self._pending:
                    self._request(P.Cmd.QUEUE_CURRENT_INDEX, 0x00, on_reply=self._on_index)
                    self._request(P.Cmd.QUEUE_LEFT_SPACE, 0x00, on_reply=self._on_left_space)
                self._request(P.Cmd.GET_POSE, 0x00, on_reply=self._on_pose)
        if fail and req is not None:  # fail is set only with a request outstanding
            self.lose_link(f"link lost: no reply to command {req.id} after {req.tries} tries")
            return
        if lost is not None:
            lost()
        if resend is not None:
            self._transmit(resend)
        self._send_next()

    # ------------------------------------------------------------------ requests

    def _request(
        self,
        cid: int,
        ctrl: int,
        params: bytes = b"",
        on_reply: Callable[[P.Frame], None] | None = None,
        front: bool = False,
        on_lost: Callable[[], None] | None = None,
    ) -> None:
        req = _Request(P.encode(cid, ctrl, params), int(cid), on_reply, on_lost=on_lost)
        with self._lock:
            if front:
                self._requests.appendleft(req)
            else:
                self._requests.append(req)

    def _send_next(self) -> None:
        with self._lock:
            if self._outstanding is not None or not self._requests or self._ser is None:
                return
            req = self._requests.popleft()
            self._outstanding = req
        self._transmit(req)

    def _transmit(self, req: _Request) -> None:
        req.sent_at = self._now if math.isfinite(self._now) else self._current_time()
        req.tries += 1
        self.write(req.frame)

    def _on_pose(self, frame: P.Frame) -> None:
        if len(frame.params) < 32:
            self.guard.refused("a pose reply too short to hold a pose")
            return
        vals = P.unpack_pose(frame.params)
        q = np.array(vals[4:8], dtype=float)
        # The checksum catches damage on the wire, not a device that is not the arm.
        if self.guard.check(q, self._now if math.isfinite(self._now) else 0.0) is not None:
            return
        self._joints = q
        self.status_wall = time.perf_counter()
        self._update_progress()

    def _on_index(self, frame: P.Frame) -> None:
        if len(frame.params) >= 8:
            self._current_index = P.unpack_index(frame.params)
            self._update_progress()

    def _on_left_space(self, frame: P.Frame) -> None:
        if len(frame.params) >= 4:
            self.left_space = struct.unpack_from("<I", frame.params)[0]

    def _update_progress(self) -> None:
        with self._lock:
            pending = list(self._pending)
        done = []
        for p in pending:
            if p.index is not None and self._current_index >= p.index:
                for action in p.extra:
                    action()
                p.handle.update(MotionStatus.DONE)
                done.append(p)
            elif p.index is not None and p.goal is not None and self._joints is not None:
                total = float(np.linalg.norm(p.goal - p.start))
                left = float(np.linalg.norm(p.goal - self._joints))
                prog = 1.0 - left / total if total > 0 else 0.0
                p.handle.update(MotionStatus.RUNNING, progress=prog)
        with self._lock:
            self._pending = [p for p in self._pending if p not in done and not p.handle.done]

    def _queued(
        self,
        description: str,
        cid: int,
        params: bytes,
        goal: np.ndarray | None = None,
        extra: list[Callable[[], None]] | None = None,
        resend: bool = True,
    ) -> MotionHandle:
        """Send one queued command; the handle is DONE when the arm has executed it.

        With ``resend=False`` (incremental moves) a lost reply fails the handle
        instead of resending: the arm may have queued the command already, and
        running a relative move twice would go too far.
        """
        fault = self.ensure_connected()
        if fault is not None:
            return self.refused(description, fault)
        handle = self.track(MotionHandle(description, goal))
        pending = _Pending(handle, None, self._joints, goal, extra or [])

        def on_reply(frame: P.Frame) -> None:
            if len(frame.params) < 8:
                handle.update(
                    MotionStatus.FAILED,
                    error=HardwareFault("the arm's command queue is full", self.device),
                )
                return
            pending.index = P.unpack_index(frame.params)
            handle.update(MotionStatus.RUNNING, progress=0.0)

        def on_lost() -> None:
            handle.update(
                MotionStatus.FAILED,
                error=HardwareFault(
                    f"{description}: no reply, not resent (the arm may have queued it)",
                    self.device,
                ),
            )

        with self._lock:
            self._pending.append(pending)
        self._request(
            cid,
            P.CTRL_WRITE | P.CTRL_QUEUED,
            params,
            on_reply=on_reply,
            on_lost=None if resend else on_lost,
        )
        self._send_next()
        return handle

    # ------------------------------------------------------------------ ArmDriver

    def joints(self) -> np.ndarray:
        """Joints j1..j4 as last reported by GetPose, degrees."""
        return self.model.home.copy() if self._joints is None else self._joints.copy()

    @property
    def tool(self) -> ToolState:
        """The suction cup and gripper as last commanded and executed."""
        return self._tool

    def move_ptp(self, mode: int, target: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """A PTP move in any :class:`~.protocol.PTPMode`; ``target`` is its four floats.

        Absolute Cartesian and joint targets are checked against the model
        first; incremental modes are checked from the reported joints.
        """
        target = np.asarray(target, dtype=float).reshape(-1)
        desc = f"PTP {P.PTPMode(mode).name if mode in P.PTPMode._value2member_map_ else mode} {np.round(target, 2).tolist()}"
        try:
            if target.shape != (4,):
                raise Unreachable(
                    f"{self.model.name}: PTP target {target.tolist()} is not four numbers"
                )
            if not np.all(np.isfinite(target)):
                raise Unreachable(f"{self.model.name}: PTP target {target.tolist()} is not finite")
            goal = self._goal_joints(int(mode), target)
        except Unreachable as exc:
            return self.refused(desc, exc)
        key = ("ptp", int(mode), tuple(np.round(target, 4)), round(float(speed), 4))
        if self.is_duplicate(key) and self._last_handle is not None and not self._last_handle.done:
            return self._last_handle
        ratio = float(min(max(speed, 0.01), 1.0)) * 100.0
        if ratio != self._ratio_sent:  # the speed ratio stays set in the arm until changed
            self._request(
                P.Cmd.PTP_COMMON_PARAMS,
                P.CTRL_WRITE | P.CTRL_QUEUED,
                struct.pack("<2f", ratio, ratio),
            )
            self._ratio_sent = ratio
        incremental = int(mode) in (P.PTPMode.MOVJ_INC, P.PTPMode.MOVL_INC, P.PTPMode.MOVJ_XYZ_INC)
        handle = self._queued(
            desc, P.Cmd.PTP, P.ptp_params(int(mode), *target), goal=goal, resend=not incremental
        )
        self.remember_sent(key)
        self._last_handle = handle
        return handle

    def _goal_joints(self, mode: int, target: np.ndarray) -> np.ndarray:
        q = self.joints()
        if mode in (0, 1, 2, 9):
            goal = self.model.ik(target[:3], near=q)
            goal[3] = target[3] - goal[0]
        elif mode in (3, 4, 5):
            goal = target.copy()
        elif mode == 6:
            goal = q + target
        elif mode in (7, 8):
            p = self.model.pose_xyzr(q) + target
            goal = self.model.ik(p[:3], near=q)
            goal[3] = p[3] - goal[0]
        else:
            raise Unreachable(f"{self.model.name}: unknown PTP mode {mode}")
        goal = self.checked_joints(goal)
        if mode in (0, 2, 3, 5, 7, 9):
            # straight lines and jumps: every point of the path must be reachable, as the
            # firmware will refuse the whole command (and not move) otherwise
            try:
                self._paths.plan(mode, target, q, 0.0)
            except ValueError as exc:
                raise Unreachable(
                    f"{self.model.name}: PTP {P.PTPMode(mode).name} to "
                    f"{np.round(target, 2).tolist()}: the path leaves the workspace ({exc})"
                ) from exc
        return goal

    def move_joints(self, q: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Joint move (MOVJ_ANGLE) to ``q`` (degrees)."""
        return self.move_ptp(P.PTPMode.MOVJ_ANGLE, np.asarray(q, dtype=float), speed)

    def move_to(self, xyz: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Joint-interpolated move (MOVJ_XYZ) of the tool to ``xyz`` (mm), keeping r."""
        xyz = np.asarray(xyz, dtype=float).reshape(-1)
        if xyz.shape != (3,):
            return self.refused(
                "move", Unreachable(f"{self.model.name}: {xyz.tolist()} is not x, y, z")
            )
        r = float(self.model.pose_xyzr(self.joints())[3])
        return self.move_ptp(P.PTPMode.MOVJ_XYZ, np.append(xyz, r), speed)

    def move_linear(self, xyz: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Straight-line move (MOVL_XYZ) of the tool to ``xyz`` (mm), keeping r."""
        r = float(self.model.pose_xyzr(self.joints())[3])
        return self.move_ptp(
            P.PTPMode.MOVL_XYZ, np.append(np.asarray(xyz, float).reshape(-1)[:3], r), speed
        )

    def set_suction(self, on: bool) -> MotionHandle:
        """Switch the suction cup (queued after the moves before it)."""
        key = ("suction", bool(on))
        if self.is_duplicate(key) and self._last_handle is not None and not self._last_handle.done:
            return self._last_handle

        def applied() -> None:
            self._tool = ToolState(suction=bool(on), gripper=self._tool.gripper)

        handle = self._queued(
            f"suction {'on' if on else 'off'}",
            P.Cmd.SUCTION_CUP,
            bytes([1, int(bool(on))]),
            extra=[applied],
        )
        self.remember_sent(key)
        self._last_handle = handle
        return handle

    def set_gripper(self, opening: float) -> MotionHandle:
        """Open (``opening`` > 0) or close (0) the Magician's pneumatic gripper."""
        grip = not opening > 0

        def applied() -> None:
            self._tool = ToolState(suction=self._tool.suction, gripper=0.0 if grip else 1.0)

        self.remember_sent(("gripper", grip))
        return self._queued(
            f"gripper {'close' if grip else 'open'}",
            P.Cmd.GRIPPER,
            bytes([1, int(grip)]),
            extra=[applied],
        )

    def set_ptp_params(
        self,
        joint_velocity: float = 200.0,
        joint_accel: float = 200.0,
        xyz_velocity: float = 200.0,
        xyz_accel: float = 200.0,
        jump_height: float = 20.0,
        z_limit: float = 200.0,
    ) -> MotionHandle:
        """Queue the PTP joint (deg/s, deg/s^2, all four joints), coordinate (mm/s, mm/s^2;
        r uses the same figures in deg/s) and jump (mm) parameters; DONE once executed."""
        values = (joint_velocity, joint_accel, xyz_velocity, xyz_accel, jump_height, z_limit)
        if not all(np.isfinite(v) and v > 0 for v in values):
            raise ValueError(f"PTP parameters must be positive finite numbers, got {values}")
        self.remember_sent(None)
        self._request(
            P.Cmd.PTP_JOINT_PARAMS,
            P.CTRL_WRITE | P.CTRL_QUEUED,
            struct.pack("<8f", *([joint_velocity] * 4 + [joint_accel] * 4)),
        )
        self._request(
            P.Cmd.PTP_COORDINATE_PARAMS,
            P.CTRL_WRITE | P.CTRL_QUEUED,
            struct.pack("<4f", xyz_velocity, xyz_velocity, xyz_accel, xyz_accel),
        )
        self._paths.joint_speed = np.full(4, float(joint_velocity))
        self._paths.joint_accel = np.full(4, float(joint_accel))
        self._paths.xyz_speed = self._paths.r_speed = float(xyz_velocity)
        self._paths.xyz_accel = self._paths.r_accel = float(xyz_accel)
        self._paths.jump_height, self._paths.z_limit = float(jump_height), float(z_limit)
        return self._queued(
            "PTP parameters", P.Cmd.PTP_JUMP_PARAMS, struct.pack("<2f", jump_height, z_limit)
        )

    def wait(self, ms: int) -> MotionHandle:
        """Queue a pause of ``ms`` milliseconds."""
        self.remember_sent(None)
        return self._queued(f"wait {ms} ms", P.Cmd.WAIT, struct.pack("<I", int(ms)))

    def home(self) -> MotionHandle:
        """The firmware's homing command (SetHOMECmd)."""
        self.remember_sent(None)
        return self._queued("home", P.Cmd.SET_HOME, struct.pack("<I", 0), goal=self.model.home)

    def stop(self) -> None:
        """Force-stop the queue at once (the arm brakes), clear it and restart it."""
        with self._lock:
            self._requests.clear()
            self._outstanding = None
            self._pending = []
        self.stop_all()
        self.remember_sent(None)
        self._last_handle = None
        self._ratio_sent = None  # a cleared queue may have dropped the last speed setting
        if self._ser is None:
            return
        self.write(P.encode(P.Cmd.QUEUE_FORCE_STOP, 0x01))
        # the force-stop's own reply is ignored; clear and restart go through the request queue
        self._request(P.Cmd.QUEUE_CLEAR, 0x01)
        self._request(P.Cmd.QUEUE_START, 0x01)
