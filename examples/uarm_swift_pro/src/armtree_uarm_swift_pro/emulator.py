"""The uArm Swift Pro's firmware V4 (Grbl-based), byte for byte, behind a pseudo-terminal.

What it reproduces, from the firmware's source (``protocol.c``,
``uarm_protocol.c``, ``motion_control.c``) and the protocol document V4.2.0:

* line reading: ``\\n`` or ``\\r`` ends a line; bytes up to space are dropped,
  letters upper-cased, ``(...)`` and ``;`` comments stripped; a line over 79
  characters gets ``error: E23``; after ``#n`` a command must start with G, M,
  P or S, anything else is silently ignored;
* two paths: ``P`` queries (and ``S`` commands) are answered at once, even while
  the arm moves; ``G`` and ``M`` commands queue (20; a 21st gets ``E23 buffer
  full`` with no number), are carried out in order as they arrive (a move goes
  into the 18-block planner; the pump switches at once, even while the arm
  still moves), and all their replies are printed when the arm is idle again:
  the ``ok`` of a move means it is over;
* moves: ``G0 X Y Z F`` (joint-interpolated), ``G1`` (a straight line, F
  clamped to 100; the tool runs at F x 80 / 60 mm/s, assumed), ``G2204`` (relative), ``G2202 N V F`` (one joint; N3 the
  wrist servo), ``G2004 P`` (a pause); an unreachable target is ``E22``, any move
  with the motors detached (``M2019``) is ``E27``, and ``F0``, or no F since
  boot, answers ``ok`` without moving; a joint moves at ``F`` x 80 degrees per
  minute (the planner counts 6400 steps per 80 degrees; derived from the source,
  not measured), within the model's limits;
* ``M17`` / ``M2019`` motors on / off, ``M2231 V`` pump, ``M2232 V`` gripper,
  ``M2120 V<s>`` periodic ``@3`` position reports, ``M2400 S<digit>`` work mode;
* ``P2200`` joint angles (from the encoders: missed steps show), ``P2201``
  ``SwiftPro``, ``P2202``-``P2205`` versions and id, ``P2206 N``, ``P2220`` /
  ``P2221`` position, ``P2231`` / ``P2232`` pump and gripper, ``P2234`` power,
  ``P2400`` mode; ``S1100`` resets motion (the arm stops, the queue empties;
  what the firmware prints for the dropped commands is not documented: nothing);
* the boot banner (``device name : SwiftPro`` ... ``@1``, then ``@5 V1``) when the
  host first talks, as the board resets when its port is opened.

Units: mm and degrees; times in seconds on the run's clock.
"""

from __future__ import annotations

import collections
import math

import numpy as np
from armtree.api.clock import Clock
from armtree.api.rig import ToolState
from armtree.errors import Unreachable
from armtree.plugins.arms.common import LineMove, PtyEmulator

from . import protocol as P
from .kinematics import MODES, SwiftProModel

BANNER = (
    "angle offset:0.0000\r\n"
    "device name : SwiftPro\r\n"
    "soft ver : V4.10.0\r\n"
    "api ver : V4.0.5\r\n"
    "work mode : {mode}\r\n"
    "@1\n"
    "@5 V1\n"
)
#: Unparsed G/M commands the firmware holds (PACK_MAX_SIZE), and planner blocks.
QUEUE_SIZE, PLANNER_SIZE = 20, 18
#: Degrees per F unit per minute of joint motion (6400 steps per 80 degrees).
DEGREES_PER_F_MINUTE = 80.0
VERSIONS = {2202: "V3.3.1", 2203: "V4.10.0", 2204: "V4.0.5", 2205: "V2E0A1B4C5D6F"}


class SwiftProEmulator(PtyEmulator):
    """Firmware V4.10 of a Swift Pro on its Mega 2560, with the standard suction cup."""

    def __init__(
        self, model: SwiftProModel, clock: Clock, *, seed: int = 0, q0: np.ndarray | None = None
    ) -> None:
        super().__init__(model, clock, seed=seed, q0=q0)
        self.model: SwiftProModel = model
        self.pump = False
        self.gripper = False
        self.wrist = 90.0
        self.attached = True
        self._feed: float | None = None  # no F since boot: moves answer ok and stay
        self._booted = False
        self._partial = b""
        self._queue: collections.deque[P.HostLine] = collections.deque()
        self._unreported: list[str] = []
        self._planner: collections.deque[tuple[np.ndarray, float, bool]] = collections.deque()
        self._planned_end = np.asarray(self.joints.reported(self.time), dtype=float)
        self._delay_until = -math.inf
        self._report_period = 0.0
        self._next_report = math.inf

    # ------------------------------------------------------------------ PtyEmulator hooks

    def on_bytes(self, data: bytes, t: float) -> None:
        """Split lines, answer queries at once, queue G/M commands, then run the queue."""
        if not self._booted:
            self._booted = True
            self._say(BANNER.format(mode=self.model.mode))
        buffer = self._partial + data
        *lines, self._partial = buffer.replace(b"\r", b"\n").split(b"\n")
        if len(self._partial) > 256:
            self._partial = b""  # noise without a line end: dropped, as the serial buffer would
        for raw in lines:
            text = raw.decode("ascii", "replace")
            if len(text) > P.MAX_LINE:
                self._say("error: E23\r\n")
                continue
            line = P.read_host_line(text)
            if line is None:
                continue
            if line.command[0] in "PS":
                self._say(self._immediate(line, t))
            elif len(self._queue) >= QUEUE_SIZE:
                self._say("E23 buffer full\r\n")
            else:
                self._queue.append(line)
                self._run(t)  # the main loop parses between received lines

    def next_event_time(self) -> float | None:
        """The end of the current move or pause, or the next periodic report."""
        times = [self._next_report]
        if self.joints.moving(self.time) or self._planner:
            times.append(self.joints.end_time)
        if self._delay_until > self.time:
            times.append(self._delay_until)
        later = [x for x in times if math.isfinite(x) and x > self.time]
        return min(later) if later else None

    def on_timer(self, t: float) -> None:
        """Start planned moves, finish pauses, print due replies and reports."""
        if t >= self._next_report:
            q = self.joints.true(t)
            x, y, z = self.model.position(q)
            self._say(f"@3 X{P.fmt4(x)} Y{P.fmt4(y)} Z{P.fmt4(z)} R{P.fmt4(self.wrist)}\n")
            self._next_report = t + self._report_period
        self._run(t)

    def tool(self) -> ToolState:
        """The suction pump as the firmware drives it."""
        return ToolState(suction=self.pump)

    def halt(self, reason: str) -> None:
        """Stop dead (a crash): the planner and the queue are emptied."""
        with self._lock:
            super().halt(reason)
            self._planner.clear()
            self._queue.clear()
            self._planned_end = self.joints.reported(self.time)

    # ------------------------------------------------------------------ the queue

    def _say(self, text: str) -> None:
        self.send(text.encode("ascii", "replace"))

    def _idle(self, t: float) -> bool:
        return not self._planner and not self.joints.moving(t) and t >= self._delay_until

    def _run(self, t: float) -> None:
        self._advance_motion(t)
        while self._queue and t >= self._delay_until and len(self._planner) < PLANNER_SIZE:
            line = self._queue.popleft()
            self._unreported.append(P.reply(line.number, *self._execute(line, t)))
            self._advance_motion(t)
        if self._unreported and self._idle(t):
            self._say("".join(self._unreported))
            self._unreported.clear()

    def _advance_motion(self, t: float) -> None:
        while self._planner and not self.joints.moving(t):
            # on_timer runs at the very end of the previous move, so the next starts now
            goal, rate, straight = self._planner.popleft()
            if straight:
                start = self.joints.reported(t)
                move = LineMove(
                    lambda p, near=start: self._ik_or_nan(p, near),
                    start,
                    goal,
                    self.model.position,
                    t,
                    max_speed=rate,
                    max_accel=4 * rate,
                )
                self.joints.start(move)
            else:
                fastest = float(np.max([j.max_speed for j in self.model.joints]))
                self.joints.move_to(goal, t, min(1.0, rate / fastest))

    def _ik_or_nan(self, point: np.ndarray, near: np.ndarray) -> np.ndarray:
        try:
            return self.model.ik(point, near=near)
        except Unreachable:
            return np.full(self.model.dof, np.nan)

    def _plan(
        self, goal: np.ndarray, feed: float | None, straight: bool = False
    ) -> tuple[str, str]:
        if feed is not None and feed > 0:
            self._feed = feed
        if not self._feed:
            return "ok", ""  # F0 or no F since boot: nothing moves
        feed = min(self._feed, 100.0) if straight else self._feed
        self._planner.append((goal, feed * DEGREES_PER_F_MINUTE / 60.0, straight))
        self._planned_end = goal
        return "ok", ""

    def _move_to(self, xyz: np.ndarray, feed: float | None, straight: bool) -> tuple[str, str]:
        if not self.attached:
            return "E27", ""
        try:
            goal = self.model.ik(xyz, near=self._planned_end)
        except Unreachable:
            return "E22", ""
        return self._plan(goal, feed, straight)

    def _execute(self, line: P.HostLine, t: float) -> tuple[str, str]:
        """Carry out one G or M command: (status, payload) of its reply."""
        code, args = P.split_command(line.command)
        current = self.model.position(self._planned_end)
        if code in ("G0", "G1"):
            xyz = np.array([args.get(a, current[i]) for i, a in enumerate("XYZ")])
            return self._move_to(xyz, args.get("F"), straight=code == "G1")
        if code == "G2204":
            if not {"X", "Y", "Z", "F"} <= args.keys():
                return "E21", ""
            offset = np.array([args["X"], args["Y"], args["Z"]])
            return self._move_to(current + offset, args["F"], straight=True)
        if code == "G2202":
            return self._joint_move(args)
        if code == "G2004":
            self._delay_until = t + args.get("P", 0.0) / 1000.0
            return "ok", ""
        if code == "M17":
            self.attached = True
            return "ok", ""
        if code in ("M2019", "M18"):
            self.attached = False
            return "ok", ""
        if code in ("M2231", "M2232"):
            value = args.get("V")
            if value not in (0.0, 1.0, 2.0) or (code == "M2232" and value == 2.0):
                return "E21", ""
            if code == "M2231":
                self.pump = value > 0
            else:
                self.gripper = value > 0
            return "ok", ""
        if code == "M2120":
            period = args.get("V", 0.0)
            self._report_period = period
            self._next_report = t + period if period > 0 else math.inf
            return "ok", ""
        if code == "M2400":
            mode = int(args.get("S", -1)) % 10 if "S" in args else -1
            if mode not in MODES:
                return "E21", ""
            return "ok", ""  # the tool offsets follow the model the emulator was built with
        if code in ("M204", "M2122", "M2123"):
            return "ok", ""
        return "E20", ""

    def _joint_move(self, args: dict[str, float]) -> tuple[str, str]:
        if not {"N", "V", "F"} <= args.keys():
            return "E21", ""
        joint = int(args["N"])
        if joint == 3:
            self.wrist = float(args["V"]) % 181.0
            return "ok", ""
        if joint not in (0, 1, 2):
            return "E21", ""
        if not self.attached:
            return "E27", ""
        goal = self._planned_end.copy()
        goal[joint] = args["V"]
        if not bool(self.model.within_limits(goal)):
            return "E22", ""
        return self._plan(goal, args["F"])

    # ------------------------------------------------------------------ queries

    def _immediate(self, line: P.HostLine, t: float) -> str:
        """The reply to a P query or an S command, printed at once."""
        code, args = P.split_command(line.command)
        n = line.number
        q = self.joints.true(t)  # the encoders see where the arm really is
        if code == "P2200":
            return P.reply(n, "ok", f"B{P.fmt4(q[0])} L{P.fmt4(q[1])} R{P.fmt4(q[2])}")
        if code == "P2206" and int(args.get("N", -1)) in (0, 1, 2, 3):
            joint = int(args["N"])
            return P.reply(n, "ok", f"V{P.fmt4(self.wrist if joint == 3 else q[joint])}")
        if code == "P2201":
            return P.reply(n, "ok", "SwiftPro")
        if code in ("P2202", "P2203", "P2204", "P2205"):
            return P.reply(n, "ok", VERSIONS[int(code[1:])])
        if code == "P2220":
            x, y, z = self.model.position(q)
            return P.reply(n, "ok", f"X{P.fmt4(x)} Y{P.fmt4(y)} Z{P.fmt4(z)}")
        if code == "P2221":
            x, y, z = self.model.position(q)
            rotation = math.degrees(math.atan2(y, x)) + 90.0
            return P.reply(n, "ok", f"S{P.fmt4(math.hypot(x, y))} R{P.fmt4(rotation)} H{P.fmt4(z)}")
        if code == "P2231":
            return P.reply(n, "ok", f"V{int(self.pump)}")
        if code == "P2232":
            return P.reply(n, "ok", f"V{int(self.gripper)}")
        if code == "P2234":
            return P.reply(n, "ok", "V1")
        if code == "P2400":
            return P.reply(n, "ok", f"V{self.model.mode}")
        if code == "S1100":
            self.joints.brake(t)
            self._planner.clear()
            self._queue.clear()
            self._unreported.clear()
            self._delay_until = -math.inf
            self._planned_end = np.asarray(self.joints.reported(self.joints.end_time), dtype=float)
            return P.reply(n, "ok")
        if code == "S1000":
            return P.reply(n, "ok")
        return P.reply(n, "E20")
