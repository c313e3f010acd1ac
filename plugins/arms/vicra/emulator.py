"""The VICRA arm's Marlin firmware (Mega 2560 + RAMPS 1.4) behind a pseudo-terminal.

Marlin drives the arm as a plain joint controller (Marlin's SCARA support,
last point): X is the shoulder theta1 and Y the elbow theta2 (degrees), Z the
column (mm); servo 0 is the wrist (M280 S = wrist + 90), servo 1 the gripper
(S = opening in degrees); a vacuum pump, when fitted, is on the fan output
(M106 / M107). End stops: x_min at theta1's lower limit, y_max at theta2's upper
one (so homing leaves the elbow on the same side as the home pose),
z_max at the top of the column (Durovic 2017: micro-switches on all three axes).

What it reproduces (Marlin 2.0.x): the start-up banner (printed when the host
first talks, as the board resets on a port open), ``N``/``*`` line checks with
``Error:`` + ``Resend:`` + ``ok`` (Marlin 2.1) and a flushed receive buffer, a
4-line command ring, ``ok`` only once a command has been executed (G0/G1 when
planned into the 16-block planner, G28 / G4 / M400 when finished) with
``echo:busy: processing`` every 2 s meanwhile, M410 and M112 acted on as they
arrive (EMERGENCY_PARSER), moves refused before homing (``echo:Home XYZ First``,
NO_MOTION_BEFORE_HOMING), M114 (``M114 R``: real-time position), M119, M280,
M115, M110, G90/G91/G92, M17/M18/M84. At power-up the firmware believes it is at
zero while the arm is wherever it was left (by default parked on its end stops):
only G28 makes the two agree.
Units: mm, degrees, seconds on the run's clock.
"""

from __future__ import annotations

import collections
import math

import numpy as np

from armtree.api.clock import Clock
from armtree.api.rig import ToolState
from armtree.plugins.arms.common.framing import LineParser
from armtree.plugins.arms.common.pty_emulator import PtyEmulator

from . import gcode as G
from .kinematics import VicraModel

BANNER = (
    "start\n"
    "echo: External Reset\n"
    "Marlin 2.1.2.1\n"
    "echo: Last Updated: 2023-05-20 | Author: (VICRA, Mega2560 + RAMPS 1.4)\n"
    "echo: Compiled: May 20 2023\n"
    "echo: Free Memory: 2837  PlannerBufferBytes: 1168\n"
)
M115_REPORT = (
    "FIRMWARE_NAME:Marlin 2.1.2.1 (May 20 2023) SOURCE_CODE_URL:github.com/MarlinFirmware/Marlin "
    "PROTOCOL_VERSION:1.0 MACHINE_TYPE:VICRA EXTRUDER_COUNT:0 "
    "UUID:cede2a2f-41a2-4748-9b12-c55c62f367ff"
)
#: Marlin's command ring (BUFSIZE), planner depth (BLOCK_BUFFER_SIZE), line length (MAX_CMD_SIZE).
BUFSIZE, BLOCK_BUFFER_SIZE, MAX_CMD_SIZE = 4, 16, 96
#: The Mega's serial receive buffer (bytes) while the command ring is full.
RX_BUFFER_SIZE = 128
#: Steps per degree (X, Y: 3200 steps/rev through 4.5:1 belts) and per mm (Z: 8 mm lead screw).
STEPS_PER_UNIT = np.array([40.0, 40.0, 400.0])
KEEPALIVE = 2.0
#: Homing feed as a fraction of each axis' maximum speed.
HOMING_SPEED = 0.8
#: The end stop each axis homes on.
_SWITCH = {"X": "x_min", "Y": "y_max", "Z": "z_max"}


class MarlinEmulator(PtyEmulator):
    """Marlin 2.1 on a Mega + RAMPS driving the VICRA SCARA's three steppers and two servos."""

    def __init__(
        self, model: VicraModel, clock: Clock, *, seed: int = 0, q0: np.ndarray | None = None
    ) -> None:
        # by default the arm was switched off parked on its end stops, as after a homing
        q_true = np.asarray(model.park if q0 is None else q0, dtype=float)
        super().__init__(model, clock, seed=seed, q0=np.array([0.0, 0.0, 0.0, 0.0]))
        self.model: VicraModel = model
        # the firmware believes every axis is at 0; the arm is really at q_true
        self.joints.miss_steps(0, q_true[0])
        self.joints.miss_steps(1, q_true[1])
        self.joints.miss_steps(2, q_true[2])
        self.servo = [float(q_true[3] + 90.0), 90.0]
        self.pump = False
        self.homed = False
        self.killed = False
        self.relative = False
        self.last_n = 0
        self.overflows = 0
        self.endstops = {
            "x_min": (1, model.joints[1].lower),
            "y_max": (2, model.joints[2].upper),
            "z_max": (0, model.joints[0].upper),
        }
        self._lines = LineParser(max_line=256)
        self._rx: collections.deque[str] = collections.deque()
        self._ring: collections.deque[G.HostLine] = collections.deque()
        self._planner: collections.deque[tuple[np.ndarray, float, float]] = collections.deque()
        self._feed = 6000.0
        self._homing_axes: list[str] = []
        self._destination = np.zeros(4)
        self._blocking: tuple[str, float] | None = None
        self._busy_at = math.inf
        self._booted = False

    # ------------------------------------------------------------------ PtyEmulator hooks

    def on_bytes(self, data: bytes, t: float) -> None:
        """Read lines; emergency commands act at once; then run the command loop."""
        if self.killed:
            return
        if not self._booted:
            self._booted = True
            self._say(BANNER.rstrip("\n"))
        for raw in self._lines.feed(data.replace(b"\r", b"\n")):
            raw = raw[: MAX_CMD_SIZE - 1]
            if not raw.strip():
                continue
            code, _ = G.words(G.parse_host_line(raw).command)
            if code == "M112":
                self._kill(t)
                return
            if code == "M410":
                self._quickstop(t)
            if sum(len(x) + 1 for x in self._rx) + len(raw) + 1 > RX_BUFFER_SIZE:
                self.overflows += 1  # a full receive buffer loses what arrives
                continue
            self._rx.append(raw)
        self._run(t)

    def next_event_time(self) -> float | None:
        """End of the current move or blocking command, or the next keep-alive."""
        times = []
        if self._planner or self.joints.moving(self.time):
            times.append(self.joints.end_time)
        if self._blocking is not None:
            kind, until = self._blocking
            if kind == "G4":
                times.append(until)
            times.append(self._busy_at)
        times = [x for x in times if x > self.time]
        return min(times) if times else None

    def on_timer(self, t: float) -> None:
        """Advance the planner, finish blocking commands, print keep-alives."""
        if self.killed:
            return
        if self._blocking is not None and t >= self._busy_at:
            self._say("echo:busy: processing")
            self._busy_at += KEEPALIVE
        self._run(t)

    def true_joints(self) -> np.ndarray:
        """Joints in the world: steppers (missed steps included) and the wrist servo."""
        with self._lock:
            q = self.joints.true(self.time)
            q[3] = self.servo[0] - 90.0
            return q

    def reported_joints(self) -> np.ndarray:
        """Joints as the firmware counts them."""
        with self._lock:
            q = self.joints.reported(self.time)
            q[3] = self.servo[0] - 90.0
            return q

    def tool(self) -> ToolState:
        """Pump (fan output) and gripper servo opening in degrees."""
        return ToolState(suction=self.pump, gripper=self.servo[1])

    def halt(self, reason: str) -> None:
        """Stop dead (a crash): the planner is emptied."""
        with self._lock:
            super().halt(reason)
            self._planner.clear()

    # ------------------------------------------------------------------ the command loop

    def _say(self, text: str) -> None:
        self.send((text + "\n").encode("ascii", "replace"))

    def _run(self, t: float) -> None:
        while True:
            self._advance_motion(t)
            if self._blocking is not None:
                if not self._blocking_done(t):
                    return
                self._blocking = None
                self._busy_at = math.inf
                self._say("ok")
            self._fill_ring()
            if not self._ring:
                return
            if not self._execute(self._ring.popleft(), t):
                return

    def _fill_ring(self) -> None:
        """Move received lines into the ring, checking numbers and checksums ([MARLIN queue.cpp])."""
        while self._rx and len(self._ring) < BUFSIZE:
            line = G.parse_host_line(self._rx.popleft())
            code, args = G.words(line.command)
            if line.number is not None:
                if line.problem == "checksum":
                    self._resend("checksum mismatch")
                    return
                if line.problem == "no_checksum":
                    self._resend("No Checksum with line number")
                    return
                if code == "M110":
                    pass
                elif line.number != self.last_n + 1:
                    self._resend("Line Number is not Last Line Number+1")
                    return
                else:
                    self.last_n = line.number
            if code == "M110":
                self.last_n = int(args.get("N", line.number if line.number is not None else 0))
            self._ring.append(line)

    def _resend(self, why: str) -> None:
        self._rx.clear()  # flush_and_request_resend() empties the receive buffer first
        self._say(f"Error:{why}, Last Line: {self.last_n}")
        self._say(f"Resend: {self.last_n + 1}")
        self._say("ok")

    def _blocking_done(self, t: float) -> bool:
        kind, until = self._blocking  # type: ignore[misc]
        if kind == "G4":
            return t >= until
        if self._planner or self.joints.moving(t):
            return False
        if kind == "G28":
            self._finish_homing(t)
        return True

    def _block(self, kind: str, t: float, until: float = 0.0) -> bool:
        self._blocking = (kind, until)
        self._busy_at = t + KEEPALIVE
        if not self._blocking_done(t):
            return False
        self._blocking = None
        self._busy_at = math.inf
        self._say("ok")
        return True

    def _execute(self, line: G.HostLine, t: float) -> bool:
        """Run one command; False while it blocks (its ``ok`` comes later)."""
        code, args = G.words(line.command)
        if code in ("G0", "G1"):
            if len(self._planner) >= BLOCK_BUFFER_SIZE:
                self._ring.appendleft(line)  # planner full: wait, no ok yet
                return False
            if not self.homed:
                self._say("echo:Home XYZ First")
            else:
                self._plan_move(args, t)
        elif code == "G28":
            self._start_homing(args, t)
            return self._block("G28", t)
        elif code == "G4":
            ms = args.get("P", 0.0) + 1000.0 * args.get("S", 0.0)
            return self._block("G4", t, t + ms / 1000.0)
        elif code == "M400":
            return self._block("M400", t)
        elif code == "G90":
            self.relative = False
        elif code == "G91":
            self.relative = True
        elif code == "G92":
            q = self.joints.reported(t)
            for axis, idx in (("X", 1), ("Y", 2), ("Z", 0)):
                if axis in args:
                    self.joints.missed[idx] += q[idx] - args[axis]
                    q[idx] = args[axis]
            self.joints.set(q)
            self._destination = q.copy()
        elif code == "M114":
            self._report_position(t, realtime="R" in args)
        elif code == "M119":
            self._say("Reporting endstop status")
            q = self.joints.true(t)
            for name, (idx, pos) in self.endstops.items():
                hit = abs(q[idx] - pos) < 0.05
                self._say(f"{name}: {'TRIGGERED' if hit else 'open'}")
        elif code == "M280":
            i = int(args.get("P", -1))
            if not 0 <= i < len(self.servo):
                self._say(f"Error:Servo {i} out of range")
            elif "S" not in args:
                self._say(f"echo: Servo {i}: {int(round(self.servo[i]))}")
            elif args["S"] >= 0:
                self.servo[i] = float(min(max(args["S"], 0.0), 180.0))
        elif code == "M106":
            self.pump = args.get("S", 255.0) > 0
        elif code == "M107":
            self.pump = False
        elif code in ("M18", "M84"):
            self.homed = False  # steppers released: the position is no longer known
        elif code == "M115":
            self._say(M115_REPORT)
        elif code in ("M17", "M110", "M410", "M999", "M120", "M121", "M113"):
            pass
        else:
            self._say(f'echo:Unknown command: "{line.command}"')
        self._say("ok")
        return True

    # ------------------------------------------------------------------ motion

    def _plan_move(self, args: dict[str, float], t: float) -> None:
        goal = self._destination.copy()
        for axis, idx in (("X", 1), ("Y", 2), ("Z", 0)):
            if axis in args:
                goal[idx] = goal[idx] + args[axis] if self.relative else args[axis]
        # software end stops clamp the target, as Marlin's min/max_software_endstops do
        goal[:3] = np.clip(goal[:3], self.model.lower[:3], self.model.upper[:3])
        goal[3] = 0.0
        feed = args.get("F", 0.0)
        if feed > 0:
            self._feed = feed
        self._destination = goal
        self._planner.append((goal, self._feed, t))
        self._advance_motion(t)

    def _speed_fraction(self, start: np.ndarray, goal: np.ndarray, feed: float) -> float:
        delta = np.abs(goal - start)[:3]
        vmax = self.joints.max_speed[:3]
        t_full = float(np.max(delta / vmax))
        length = float(np.linalg.norm(delta))
        if length == 0 or t_full == 0:
            return 1.0
        t_feed = length / (feed / 60.0)
        return float(min(1.0, max(0.01, t_full / t_feed)))

    def _advance_motion(self, t: float) -> None:
        """Start planned blocks back to back: each begins when the previous one ends."""
        while self._planner:
            if self.joints.moving(t):
                return
            goal, feed, planned = self._planner.popleft()
            # a block starts when the previous one ends, or when it was planned if later
            start_time = max(self.joints.end_time, planned)
            q = self.joints.reported(start_time)
            self.joints.move_to(goal, start_time, self._speed_fraction(q, goal, feed))

    def _start_homing(self, args: dict[str, float], t: float) -> None:
        axes = [a for a in "XYZ" if a in args] or list("XYZ")
        self._planner.clear()
        true = self.joints.true(t)
        goal = true.copy()
        self._homing_axes = axes
        for axis in axes:
            idx, position = self.endstops[_SWITCH[axis]]
            goal[idx] = position
        goal[3] = 0.0
        # the steppers drive physically toward the switches: count from where the arm really is
        self.joints.missed[:] = 0.0
        self.joints.set(true)
        self.joints.move_to(goal, t, HOMING_SPEED)

    def _finish_homing(self, t: float) -> None:
        # Marlin drives an axis until its switch closes, however many steps that takes:
        # a step missed on the way does not move where the axis stops (the counted move
        # here stands in for that search, so the slip is taken out at the switch)
        for axis in self._homing_axes:
            self.joints.missed[self.endstops[_SWITCH[axis]][0]] = 0.0
        q = self.joints.reported(t)
        self.joints.set(q)
        self._destination = q.copy()
        self._destination[3] = 0.0
        if set(self._homing_axes) == set("XYZ"):
            self.homed = True

    def _report_position(self, t: float, realtime: bool) -> None:
        q = self.joints.reported(t) if realtime else self._destination
        counts = tuple(int(round(v)) for v in np.array([q[1], q[2], q[0]]) * STEPS_PER_UNIT)
        self._say(G.format_m114(q[1], q[2], q[0], counts))  # type: ignore[arg-type]

    def _quickstop(self, t: float) -> None:
        """M410: abort every planned move and stop the steppers where they are."""
        if self._blocking is not None and self._blocking[0] == "G28":
            self._homing_axes = []  # homing cut short: the switches were not reached
        self._planner.clear()
        self.joints.halt(t)
        self._destination = self.joints.reported(t)
        self._destination[3] = 0.0

    def _kill(self, t: float) -> None:
        """M112: everything stops; the board answers nothing more until it is reset."""
        self._quickstop(t)
        self._say("echo:M112 Shutdown")
        self._say("Error:Printer halted. kill() called!")
        self.killed = True
