"""Dobot Magician firmware, byte for byte, behind a pseudo-terminal.

What it reproduces (Dobot DLL, pydobot 1.3.2):

* 0xAA 0xAA frames; a frame whose checksum is wrong is ignored without a
  reply, as the arm does (so pydobot's checksum bug shows up as a timeout);
* every request gets exactly one reply echoing its id and ctrl; a queued
  command (ctrl bit 1) is answered with its uint64 queue index;
* a command queue executed in order when started (240), stopped after the
  current command (241), force-stopped at once (242), cleared (245);
  GetQueuedCmdCurrentIndex (246) reports the index of the last finished
  command, GetQueuedCmdLeftSpace (247) the free slots;
* PTP moves in all ten modes with the PTP joint, coordinate, jump and common
  parameters, WAIT, HOME, suction cup and gripper, all taking effect when they
  are executed from the queue.

Units: mm, degrees, seconds on the run's clock.
"""

from __future__ import annotations

import collections
import struct
from dataclasses import dataclass

import numpy as np

from armtree.api.clock import Clock
from armtree.api.rig import ToolState
from armtree.plugins.arms.common.pty_emulator import PtyEmulator

from . import protocol as P
from .kinematics import MagicianModel
from .paths import MagicianJoints, PathPlanner

#: Commands the firmware's queue holds.
QUEUE_SIZE = 32


@dataclass
class _Queued:
    index: int
    frame: P.Frame


class MagicianEmulator(PtyEmulator):
    """The Magician's controller: frame parser, command queue and motion on the run clock."""

    def __init__(
        self, model: MagicianModel, clock: Clock, *, seed: int = 0, q0: np.ndarray | None = None
    ) -> None:
        super().__init__(model, clock, seed=seed, q0=q0)
        self.model: MagicianModel = model
        self.joints: MagicianJoints = MagicianJoints(
            model.home if q0 is None else q0,
            np.array([j.max_speed for j in model.joints]),
            np.array([j.max_accel for j in model.joints]),
        )
        self.parser = P.FrameParser()
        self.planner = PathPlanner(model)
        self.queue: collections.deque[_Queued] = collections.deque()
        self.running = True
        self.next_index = 0
        self.current_index = 0
        self._active: _Queued | None = None
        self._active_end = 0.0
        self._suction = False
        self._gripper: bool | None = None
        self.alarms: list[str] = []
        self.io: dict[int, int] = {}

    # ------------------------------------------------------------------ PtyEmulator hooks

    def on_bytes(self, data: bytes, t: float) -> None:
        """Parse frames (bad checksums dropped silently), answer each, then run the queue."""
        for frame in self.parser.feed(data):
            self._handle(frame, t)
        self._run_queue(t)

    def next_event_time(self) -> float | None:
        """End of the command being executed, if any."""
        if self._active is not None and self._active_end > self.time:
            return self._active_end
        return None

    def on_timer(self, t: float) -> None:
        """Finish commands whose time is up and start the next ones."""
        self._run_queue(t)

    def tool(self) -> ToolState:
        """Suction cup on/off and gripper (0 closed / 1 open, None if never driven)."""
        grip = None if self._gripper is None else (0.0 if self._gripper else 1.0)
        return ToolState(suction=self._suction, gripper=grip)

    def halt(self, reason: str) -> None:
        """Stop dead and drop the queue, as a crash or the e-stop would."""
        with self._lock:
            super().halt(reason)
            self.queue.clear()
            self._active = None

    # ------------------------------------------------------------------ requests

    def _reply(self, frame: P.Frame, params: bytes = b"") -> None:
        self.send(P.encode(frame.id, frame.ctrl, params))

    def _handle(self, frame: P.Frame, t: float) -> None:
        cid = frame.id
        if frame.queued:
            if len(self.queue) >= QUEUE_SIZE:
                # a full queue answers without an index; the host must wait for space
                self._reply(frame)
                return
            self.next_index += 1
            self.queue.append(_Queued(self.next_index, frame))
            self._reply(frame, P.index_params(self.next_index))
            return
        if cid == P.Cmd.GET_POSE:
            q = self.joints.reported(t)
            x, y, z, r = self.model.pose_xyzr(q)
            self._reply(frame, P.pose_params(x, y, z, r, tuple(q)))
        elif cid == P.Cmd.QUEUE_START:
            self.running = True
            self._reply(frame)
        elif cid == P.Cmd.QUEUE_STOP:
            self.running = False
            self._reply(frame)
        elif cid == P.Cmd.QUEUE_FORCE_STOP:
            self.running = False
            self._abort(t)
            self._reply(frame)
        elif cid == P.Cmd.QUEUE_CLEAR:
            self.queue.clear()
            self._reply(frame)
        elif cid == P.Cmd.QUEUE_CURRENT_INDEX:
            self._reply(frame, P.index_params(self.current_index))
        elif cid == P.Cmd.QUEUE_LEFT_SPACE:
            self._reply(frame, struct.pack("<I", QUEUE_SIZE - len(self.queue)))
        elif cid == P.Cmd.IO_DO and frame.write and len(frame.params) >= 2:
            self.io[frame.params[0]] = frame.params[1]
            self._reply(frame)
        elif cid == P.Cmd.IO_DO and len(frame.params) >= 1:
            self._reply(frame, bytes([frame.params[0], self.io.get(frame.params[0], 0)]))
        elif frame.write:
            # immediate (non-queued) set: applies at once
            self._apply(frame, t)
            self._reply(frame)
        else:
            self._reply(frame, self._get_params(cid))

    def _get_params(self, cid: int) -> bytes:
        pl = self.planner
        if cid == P.Cmd.PTP_JOINT_PARAMS:
            return struct.pack("<8f", *pl.joint_speed, *pl.joint_accel)
        if cid == P.Cmd.PTP_COORDINATE_PARAMS:
            return struct.pack("<4f", pl.xyz_speed, pl.r_speed, pl.xyz_accel, pl.r_accel)
        if cid == P.Cmd.PTP_JUMP_PARAMS:
            return struct.pack("<2f", pl.jump_height, pl.z_limit)
        if cid == P.Cmd.PTP_COMMON_PARAMS:
            return struct.pack("<2f", pl.velocity_ratio * 100, pl.accel_ratio * 100)
        if cid == P.Cmd.SUCTION_CUP:
            return bytes([1, int(self._suction)])
        if cid == P.Cmd.GRIPPER:
            return bytes([int(self._gripper is not None), int(bool(self._gripper))])
        return b""

    # ------------------------------------------------------------------ the queue

    def _abort(self, t: float) -> None:
        if self._active is not None:
            self.joints.brake(t)
            self.current_index = self._active.index
            self._active = None

    def _run_queue(self, t: float) -> None:
        while True:
            if self._active is not None:
                if self._active_end > t:
                    return
                self.current_index = self._active.index
                start = self._active_end
                self._active = None
            else:
                start = t
            if not self.running or not self.queue:
                return
            item = self.queue.popleft()
            self._active = item
            self._active_end = self._execute(item.frame, start)

    def _execute(self, frame: P.Frame, t: float) -> float:
        """Start a queued command at ``t``; returns when it ends."""
        cid = frame.id
        q = self.joints.reported(t)
        try:
            if cid == P.Cmd.PTP and len(frame.params) >= 17:
                mode, values = P.unpack_ptp(frame.params)
                path = self.planner.plan(mode, np.array(values), q, t)
                self.joints.follow(path)
                return path.end_time
            if cid == P.Cmd.SET_HOME:
                move = self.joints.move_to(self.model.home, t)
                return move.end_time
            if cid == P.Cmd.WAIT and len(frame.params) >= 4:
                return t + struct.unpack_from("<I", frame.params)[0] / 1000.0
            if cid == P.Cmd.CP and len(frame.params) >= 13:
                x, y, z = struct.unpack_from("<3f", frame.params, 1)
                target = np.array([x, y, z, self.model.pose_xyzr(q)[3]])
                if frame.params[0] == 0:  # relative
                    target[:3] += self.model.position(q)
                path = self.planner.plan(2, target, q, t)
                self.joints.follow(path)
                return path.end_time
        except (ValueError, struct.error) as exc:
            self.alarms.append(f"t={t:.3f}: {exc}")
            return t
        self._apply(frame, t)
        return t

    def _apply(self, frame: P.Frame, t: float) -> None:
        """Settings and end-effector commands (queued or immediate)."""
        cid, params = frame.id, frame.params
        pl = self.planner
        try:
            if cid == P.Cmd.SUCTION_CUP and len(params) >= 2:
                self._suction = bool(params[0]) and bool(params[1])
            elif cid == P.Cmd.GRIPPER and len(params) >= 2:
                self._gripper = bool(params[1]) if params[0] else None
            elif cid == P.Cmd.PTP_JOINT_PARAMS:
                vals = P.floats(params, 8)
                pl.joint_speed = np.maximum(np.array(vals[:4]), 1e-3)
                pl.joint_accel = np.maximum(np.array(vals[4:]), 1e-3)
            elif cid == P.Cmd.PTP_COORDINATE_PARAMS:
                v, vr, a, ar = P.floats(params, 4)
                pl.xyz_speed, pl.r_speed = max(v, 1e-3), max(vr, 1e-3)
                pl.xyz_accel, pl.r_accel = max(a, 1e-3), max(ar, 1e-3)
            elif cid == P.Cmd.PTP_JUMP_PARAMS:
                pl.jump_height, pl.z_limit = P.floats(params, 2)
            elif cid == P.Cmd.PTP_COMMON_PARAMS:
                v, a = P.floats(params, 2)
                pl.velocity_ratio = min(max(v, 1.0), 100.0) / 100.0
                pl.accel_ratio = min(max(a, 1.0), 100.0) / 100.0
        except struct.error:
            self.alarms.append(f"t={t:.3f}: short parameters for command {cid}")
