"""VICRA driver: numbered, checksummed G-code to Marlin with ``ok`` flow control.

The host does the SCARA inverse kinematics and sends joint targets as axes
(X = theta1 and Y = theta2 in degrees, Z = column in mm; see ``emulator``).
One line is in flight at a time (Marlin's flow control: the safe host
strategy); ``Resend: n`` sends line ``n`` again and swallows the ``ok`` Marlin
1.1 / 2.1 print after it. Moves are refused until G28 has homed the arm on its
end stops, confirmed by M119 (Durovic 2017: micro-switch end stops, steppers
without encoders). A move is DONE when the real-time position (``M114 R``)
reaches the target; servo commands (wrist, gripper) go after ``M400`` so they
happen once the arm has stopped. ``stop()`` sends M410, which Marlin's
emergency parser acts on as it arrives. Units: mm and degrees.
"""

from __future__ import annotations

import collections
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from armtree.api.rig import MotionHandle, MotionStatus, ToolState
from armtree.errors import HardwareFault, Unreachable
from armtree.plugins.arms.common.framing import LineParser
from armtree.plugins.arms.common.plausibility import StatusGuard
from armtree.plugins.arms.common.serial_driver import SerialArmDriver

from . import gcode as G
from .kinematics import VicraModel

#: Marlin prints M114 with two decimals.
POSITION_TOL = 0.011
BLOCKING = ("G28", "M400", "G4")
#: Reply lines kept per command (and banner lines): a device that only talks is not buffered.
MAX_KEPT = 64


@dataclass
class _Line:
    command: str
    on_ok: Callable[[list[str]], None] | None = None
    number: int | None = None
    replies: list[str] = field(default_factory=list)
    sent_at: float = -math.inf


@dataclass
class _Motion:
    handle: MotionHandle
    goal: np.ndarray
    start: np.ndarray
    planned: bool = False
    servo_done: bool = True


class VicraDriver(SerialArmDriver):
    """The VICRA SCARA on a Marlin Mega + RAMPS (115200 8N1 by default), real or emulated.

    ``home_on_connect`` queues G28 as soon as the link is up (moves sent
    meanwhile wait behind it). ``tool`` is ``"gripper"`` (servo 1; suction on
    closes it, off opens it) or ``"suction"`` (a pump on the fan output,
    M106 / M107). ``feed`` is the G1 feed rate at full speed, units per minute.
    """

    protocol = "Marlin G-code replies ('ok', 'start')"

    def __init__(
        self,
        model: VicraModel,
        port: str,
        *,
        home_on_connect: bool = True,
        tool: str = "gripper",
        feed: float = 6000.0,
        poll_period: float = 0.02,
        reply_timeout: float = 1.0,
        resend_ok: bool = True,
        **options,
    ) -> None:
        options.setdefault("baud", 115200)
        options.setdefault("link_timeout", 5.0)  # Marlin's keep-alive comes every 2 s
        super().__init__(model, port, **options)
        if tool not in ("gripper", "suction"):
            raise ValueError(f"tool must be gripper or suction, not {tool!r}")
        self.model: VicraModel = model
        self.home_on_connect = home_on_connect
        self.tool_kind = tool
        self.feed = feed
        self.poll_period = poll_period
        self.reply_timeout = reply_timeout
        self.resend_ok = resend_ok
        self.banner: list[str] = []
        self.endstops: dict[str, bool] = {}
        self._lines = LineParser(max_line=256)
        #: Doubts the positions Marlin reports and counts replies that answer nothing.
        self.guard = StatusGuard(model)
        self._lock = threading.RLock()
        self._queue: collections.deque[_Line] = collections.deque()
        self._inflight: collections.deque[_Line] = collections.deque()
        self._history: dict[int, _Line] = {}
        self._next_n = 0
        self._swallow_ok = 0
        self._ready = False
        self._homed = False
        self._homing = False
        self._settling = False
        self._joints: np.ndarray | None = None
        self._wrist = 0.0
        self._tool = ToolState()
        self._motions: list[_Motion] = []
        self._next_poll = -math.inf
        self._last_handle: MotionHandle | None = None
        #: Wall time (``time.perf_counter``) of the newest joint report, for latency figures.
        self.status_wall = 0.0

    # ------------------------------------------------------------------ public state

    @property
    def homed(self) -> bool:
        """True once G28 has run and M119 showed every end stop triggered."""
        return self._homed

    @property
    def settled(self) -> bool:
        """True once the start-up homing has finished on the end stops."""
        return self._homed and not self._settling

    def joints(self) -> np.ndarray:
        """Joints (z mm, theta1, theta2, wrist degrees) as last reported by M114 R.

        Until the start-up homing (``home_on_connect``) has ended, the counts
        mean nothing (the firmware counts from where it was powered up) and
        this returns the pose homing ends in (``model.park``, on the end
        stops): the place every move sent meanwhile starts from, since it
        waits behind the homing.
        """
        if self._settling:
            q = self.model.park.copy()
            q[3] = self._wrist
            return q
        if self._joints is None:
            return self.model.home.copy()
        q = self._joints.copy()
        q[3] = self._wrist
        return q

    @property
    def tool(self) -> ToolState:
        """Pump and gripper as last acknowledged."""
        return self._tool

    # ------------------------------------------------------------------ serial hooks

    def on_open(self) -> None:
        """Reset the line counter (``N0 M110 N0``), the handshake."""
        with self._lock:
            self._queue.clear()
            self._inflight.clear()
            self._history.clear()
            self._next_n = 0
            self._ready = False
            self.guard.reset()
        self._enqueue("M110 N0", self._on_ready)

    def handshake_done(self) -> bool:
        """True once Marlin acknowledged M110 and reported a plausible position (M114).

        An ``ok`` alone could be noise; a position within the arm's limits is not.
        """
        return self._ready and self.guard.believed > 0

    def _on_ready(self, replies: list[str]) -> None:
        self._ready = True
        self._enqueue("G90")
        self._enqueue("M280 P0", self._on_servo_report)
        self._enqueue("M114 R", self._on_position)
        self._enqueue("M119", self._on_endstops)
        if self.home_on_connect:
            self._settling = True
            self._queue_homing()

    def on_data(self, data: bytes) -> None:
        """Sort reply lines: ok, Resend, errors, keep-alives, reports (I/O thread)."""
        for raw in self._lines.feed(data):
            line = raw.strip()
            if line:
                self._on_line(line)
        verdict = self.guard.verdict()
        if verdict is not None and self._connected:
            self.lose_link(f"link lost: {verdict}")
            return
        self._pump()

    def _on_line(self, line: str) -> None:
        # Only replies that answer what was sent keep the link alive: an "ok" or a
        # "Resend" with nothing in flight is noise, and a position must be plausible.
        if G.is_ok(line):
            with self._lock:
                if self._swallow_ok:
                    self._swallow_ok -= 1
                    return
                done = self._inflight.popleft() if self._inflight else None
            if done is None:
                self.guard.refused("an 'ok' that answers no command")
                return
            if done.on_ok != self._on_position:
                self.mark_alive()
            if done.command.split()[0] == "G28":
                self.guard.rebase()  # homing sets the coordinates: the next report may jump
            if done.on_ok is not None:
                done.on_ok(done.replies)
            return
        n = G.parse_resend(line)
        if n is not None:
            if not self._inflight:
                self.guard.refused("a Resend with no command in flight")
                return
            self.mark_alive()
            self._resend(n)
            return
        if line == "start" and self._ready:
            self.lose_link("the board restarted ('start' received): its position is lost")
            return
        if line.startswith("Error:") and ("halted" in line or "kill()" in line):
            self.lose_link(f"Marlin halted: {line}")
            return
        if line.startswith("Error:") and "Last Line" in line:
            return  # the Resend that follows says what to do
        if line.startswith("echo:busy"):
            with self._lock:
                head = self._inflight[0] if self._inflight else None
            if head is not None and head.command.split()[0] in BLOCKING:
                self.mark_alive()
            return
        if not self._ready:
            if len(self.banner) < MAX_KEPT:
                self.banner.append(line)
            return
        with self._lock:
            target = self._inflight[0] if self._inflight else None
        if target is not None and len(target.replies) < MAX_KEPT:
            target.replies.append(line)

    def on_time(self, now: float) -> None:
        """Poll the position when idle; send what is queued; resend a line whose ok is overdue.

        A line that is not one of the long ones (G28, M400, G4) and got no
        ``ok`` within ``reply_timeout`` is sent again with the same number: if
        Marlin had run it and only its ``ok`` was lost, it answers with a line
        number error and ``Resend:`` of the next line, which tells the driver so.
        """
        overdue = None
        with self._lock:
            head = self._inflight[0] if self._inflight else None
            if head is not None and not math.isfinite(head.sent_at):
                head.sent_at = now  # sent before the run's first tick: its clock starts now
            if (
                head is not None
                and head.command.split()[0] not in BLOCKING
                and now - head.sent_at > self.reply_timeout
            ):
                overdue = head
            idle = not self._inflight and not self._queue
            if idle and self._ready and now >= self._next_poll:
                self._next_poll = now + self.poll_period
                self._enqueue("M114 R", self._on_position)
        if overdue is not None:
            self._transmit(overdue)
        self._pump()

    # ------------------------------------------------------------------ line traffic

    def _enqueue(self, command: str, on_ok: Callable[[list[str]], None] | None = None) -> _Line:
        line = _Line(command, on_ok)
        with self._lock:
            self._queue.append(line)
        return line

    def _pump(self) -> None:
        with self._lock:
            if self._inflight or not self._queue or self._ser is None:
                return
            line = self._queue.popleft()
            self._number(line)
        self._transmit(line)

    def _number(self, line: _Line) -> None:
        line.number = self._next_n
        self._next_n += 1
        self._inflight.append(line)
        self._history[line.number] = line
        self._history.pop(line.number - 64, None)

    def _transmit(self, line: _Line) -> None:
        line.sent_at = self._now if math.isfinite(self._now) else self._current_time()
        line.replies.clear()
        assert line.number is not None
        self.write((G.numbered(line.number, line.command) + "\n").encode("ascii"))

    def _resend(self, n: int) -> None:
        with self._lock:
            if self.resend_ok:
                self._swallow_ok += 1
            # lines before n were run (only their ok was lost): they are done
            done = []
            while self._inflight and (self._inflight[0].number or 0) < n:
                done.append(self._inflight.popleft())
            lines = [ln for ln in self._inflight if ln.number is not None and ln.number >= n]
            known = n in self._history or n == self._next_n
        for line in done:
            if line.on_ok is not None:
                line.on_ok(line.replies)
        if not known:
            self.lose_link(f"Marlin asked to resend line {n}, which was never sent")
            return
        for line in lines:
            self._transmit(line)

    # ------------------------------------------------------------------ replies

    def _on_position(self, replies: list[str]) -> None:
        believed = checked = False
        for text in replies:
            pos = G.parse_m114(text)
            if pos is None:
                continue
            q = np.array([pos.axes.get(a, math.nan) for a in ("Z", "X", "Y")] + [self._wrist])
            now = self._now if math.isfinite(self._now) else 0.0
            checked = True  # the guard counts a refused position itself
            if self.guard.check(q, now) is None:
                self._joints = q
                self.status_wall = time.perf_counter()
                believed = True
        if believed:
            self.mark_alive()
        elif not checked:
            self.guard.refused("an M114 answer without a position")
        self._update_motions()

    def _on_servo_report(self, replies: list[str]) -> None:
        for text in replies:
            if text.startswith("echo: Servo 0:") or text.startswith("echo:Servo 0:"):
                try:
                    wrist = float(text.split(":")[-1]) - 90.0
                except ValueError:
                    continue
                # the servo's own report is doubted like a position: finite, within limits
                lo, hi = self.guard.lower[3], self.guard.upper[3]
                if math.isfinite(wrist) and lo <= wrist <= hi:
                    self._wrist = wrist
                else:
                    self.guard.refused(f"a wrist servo report of {wrist + 90.0:.4g} degrees")

    def _on_endstops(self, replies: list[str]) -> None:
        for text in replies:
            hit = G.parse_endstop(text)
            if hit is not None:
                self.endstops[hit[0]] = hit[1]

    def _update_motions(self) -> None:
        if self._joints is None:
            return
        with self._lock:
            motions = list(self._motions)
        finished = []
        for m in motions:
            if m.handle.done:
                finished.append(m)
                continue
            if not m.planned:
                continue
            err = np.abs(self._joints[:3] - m.goal[:3])
            if np.all(err <= POSITION_TOL) and m.servo_done:
                m.handle.update(MotionStatus.DONE)
                finished.append(m)
            else:
                total = float(np.linalg.norm(m.goal[:3] - m.start[:3]))
                left = float(np.linalg.norm(m.goal[:3] - self._joints[:3]))
                m.handle.update(MotionStatus.RUNNING, progress=1 - left / total if total else 0)
        with self._lock:
            self._motions = [m for m in self._motions if m not in finished]

    # ------------------------------------------------------------------ homing

    def _queue_homing(self) -> None:
        self._homing = True

        def homed(replies: list[str]) -> None:
            self._on_endstops(replies)
            self._homing = False
            self._settling = False
            self._homed = all(self.endstops.get(k) for k in ("x_min", "y_max", "z_max"))

        self._enqueue("G28")
        self._enqueue("M114 R", self._on_position)
        self._enqueue("M119", homed)

    # ------------------------------------------------------------------ ArmDriver

    def _not_ready(self, description: str) -> MotionHandle | None:
        fault = self.ensure_connected()
        if fault is not None:
            return self.refused(description, fault)
        if not (self._homed or self._homing):
            return self.refused(
                description,
                HardwareFault(
                    "not homed: the arm must home on its end stops (G28) first", self.device
                ),
            )
        return None

    def move_joints(self, q: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Move to ``(z, theta1, theta2, wrist)`` (mm, degrees); the wrist turns after arrival."""
        description = f"move joints {np.round(np.asarray(q, dtype=float), 2).tolist()}"
        try:
            goal = self.checked_joints(q)
        except Unreachable as exc:
            return self.refused(description, exc)
        refusal = self._not_ready(description)
        if refusal is not None:
            return refusal
        goal = np.round(goal, 3)
        key = ("move", tuple(goal), round(float(speed), 3))
        if self.is_duplicate(key) and self._last_handle is not None and not self._last_handle.done:
            return self._last_handle
        handle = self.track(MotionHandle(description, goal))
        motion = _Motion(handle, goal, self.joints())
        feed = self.feed * float(min(max(speed, 0.01), 1.0))

        def planned(replies: list[str]) -> None:
            if any("Home" in r and "First" in r for r in replies):
                handle.update(
                    MotionStatus.FAILED,
                    error=HardwareFault("Marlin refused the move: not homed", self.device),
                )
                return
            motion.planned = True
            handle.update(MotionStatus.RUNNING, progress=0.0)

        self._enqueue(f"G1 X{goal[1]:.3f} Y{goal[2]:.3f} Z{goal[0]:.3f} F{feed:.0f}", planned)
        if abs(goal[3] - self._wrist) > 1e-3:
            motion.servo_done = False

            def servo(replies: list[str]) -> None:
                if any(r.startswith("Error:") for r in replies):
                    handle.update(
                        MotionStatus.FAILED,
                        error=HardwareFault(f"wrist servo: {replies}", self.device),
                    )
                    return
                self._wrist = float(goal[3])
                motion.servo_done = True
                self._update_motions()

            self._enqueue("M400")
            self._enqueue(f"M280 P0 S{goal[3] + 90.0:.1f}", servo)
        with self._lock:
            self._motions.append(motion)
        self.remember_sent(key)
        self._last_handle = handle
        self._pump()
        return handle

    def _servo_action(
        self, description: str, commands: list[str], state: ToolState
    ) -> MotionHandle:
        fault = self.ensure_connected()
        if fault is not None:
            return self.refused(description, fault)
        handle = self.track(MotionHandle(description))

        def done(replies: list[str]) -> None:
            if any(r.startswith("Error:") for r in replies):
                handle.update(
                    MotionStatus.FAILED,
                    error=HardwareFault(f"{description}: {replies}", self.device),
                )
                return
            self._tool = state
            handle.update(MotionStatus.DONE)

        self._enqueue("M400")
        for cmd in commands[:-1]:
            self._enqueue(cmd)
        self._enqueue(commands[-1], done)
        self.remember_sent(None)
        self._pump()
        return handle

    def set_gripper(self, opening: float) -> MotionHandle:
        """Gripper servo to ``opening`` degrees (0 closed, up to 180), after the arm stops."""
        if not (isinstance(opening, (int, float)) and 0.0 <= opening <= 180.0):
            return self.refused(
                "gripper",
                Unreachable(f"vicra: gripper opening {opening!r} is outside [0, 180] degrees"),
            )
        state = ToolState(suction=self._tool.suction, gripper=float(opening))
        return self._servo_action(f"gripper {opening:g} deg", [f"M280 P1 S{opening:.0f}"], state)

    def set_suction(self, on: bool) -> MotionHandle:
        """Pump on / off (``tool: suction``), or close / open the gripper (``tool: gripper``)."""
        if self.tool_kind == "gripper":
            return self.set_gripper(0.0 if on else 90.0)
        state = ToolState(suction=bool(on), gripper=self._tool.gripper)
        return self._servo_action(
            f"suction {'on' if on else 'off'}", ["M106 S255" if on else "M107"], state
        )

    def home(self) -> MotionHandle:
        """Home on the end stops (G28, checked with M119), then go to the model's home pose."""
        fault = self.ensure_connected()
        if fault is not None:
            return self.refused("home", fault)
        self.remember_sent(None)
        self._queue_homing()
        self._pump()
        return self.move_joints(self.model.home)

    def stop(self) -> None:
        """M410 at once (acted on by Marlin as it arrives); queued lines are dropped."""
        with self._lock:
            self._queue.clear()
            self._motions.clear()
        self.stop_all()
        self.remember_sent(None)
        self._last_handle = None
        if self._ser is None or not self._ready:
            return
        with self._lock:
            line = _Line("M410")
            self._number(line)
        self._transmit(line)
        self._enqueue("M114 R", self._on_position)

    def emergency_stop(self) -> None:
        """M112: Marlin kills the motors and stops answering until it is reset."""
        self.stop_all()
        if self._ser is not None:
            with self._lock:
                line = _Line("M112")
                self._number(line)
            self._transmit(line)
