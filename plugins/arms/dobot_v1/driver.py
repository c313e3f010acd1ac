"""The Dobot V1.0 driver for the original firmware (42-byte frames over pyserial).

It keeps the official client's rule (Dobot protocol, DobotClient): the arm streams status
frames and at most one command is written per status frame received, so the
firmware never drops one (the firmware's documented quirk). A command goes out when its status frame
arrives, or at once when asked for if no command has been written since the
last frame. The
RPI report's safeguards (Showers 2016, "Serial Interface") hold: targets are
checked before a byte is sent; a command is sent only once the move before
it is complete, judged from the arm's reported angles; and a duplicate of the
last command is not re-sent (a suction change alone goes as a jog frame).

:meth:`DobotV1Driver.home` re-references the arm the only way the stock V1.0
can: it moves the base to 0 and resets the board by reopening the port (see
:mod:`.homing`); the driver's :meth:`DobotV1Driver.step` carries it forward
once per tick.
"""

from __future__ import annotations

import collections
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from armtree.api.rig import MotionHandle, MotionStatus, ToolState
from armtree.errors import HardwareFault, Unreachable

from ..common import SerialArmDriver
from ..common.plausibility import StatusGuard
from . import codec
from .homing import BoardResetHoming, Phase, home_pose

#: Largest magnitude a believable Cartesian field of a status frame has (mm, degrees).
_FIELD_LIMIT = 10_000.0
#: Gripper angles the firmware reports (degrees), with a margin.
_GRIPPER = (-100.0, 100.0)


@dataclass
class _Pending:
    """A command waiting for its status frame, and the handle it completes."""

    command: codec.Command
    handle: MotionHandle | None
    key: object
    kind: str  # "move", "tool", "config"
    target: np.ndarray | None = None
    done_when: Callable[[codec.Status], bool] | None = None


class DobotV1Driver(SerialArmDriver):
    """Drives a Dobot V1.0 with its original firmware (angles in degrees, positions mm).

    ``tolerance`` (degrees) is how close the reported angles must come to a
    target for a move to be DONE (the report used 0.001 degrees; float32
    frames and a real arm's steps call for a little more).
    """

    protocol = "Dobot V1.0 status frames (0xA5 ... 0x5A, 42 bytes)"

    def __init__(self, *args, tolerance: float = 0.01, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.tolerance = tolerance
        self._lock = threading.RLock()
        self._parser = codec.frame_parser()
        self._queue: collections.deque[_Pending] = collections.deque()
        self._inflight: collections.deque[tuple[MotionHandle, np.ndarray, np.ndarray]] = (
            collections.deque()
        )
        self._tool_waits: list[tuple[MotionHandle, Callable[[codec.Status], bool]]] = []
        self._status: codec.Status | None = None
        self._previous: np.ndarray | None = None
        self._wrote_since_status = False
        self._suction = False
        self._gripper = 0.0
        self._last_target: np.ndarray | None = None
        self._speed = 1.0
        #: Status frames believed, for figures and tests.
        self.frames_received = 0
        # The frames carry no checksum: each is checked for plausibility before it is believed.
        self.guard = StatusGuard(self.model, frame_bytes=codec.FRAME_LEN)
        #: Commands written, for figures and tests.
        self.commands_written = 0
        self._homing: BoardResetHoming | None = None
        self._referenced = True

    # ------------------------------------------------------------------ I/O thread

    def on_open(self) -> None:
        """A fresh parser and state for a new connection (the board resets when opened)."""
        with self._lock:
            self._parser.reset()
            self._queue.clear()
            self._inflight.clear()
            self._tool_waits = []
            self._status = None
            self._previous = None
            self._wrote_since_status = False
            self._last_target = None
            self._speed = 1.0
            self.remember_sent(None)
            self.guard.reset()

    def handshake_done(self) -> bool:
        """Connected once a stable run of plausible status frames arrived (not any bytes).

        On a virtual clock no time passes while connecting, so one plausible frame
        connects; no command goes out before the run is stable either way.
        """
        return self._status is not None and (self.guard.stable or self.clock.virtual)

    def on_data(self, data: bytes) -> None:
        """Parse status frames; believe the plausible ones; after each, update handles and
        write one queued command. Mostly corrupt frames lose the link."""
        skipped = self._parser.discarded
        frames = self._parser.feed(data)
        self.guard.skipped(self._parser.discarded - skipped)
        for frame in frames:
            status = codec.Status.decode(frame)
            if self._doubt(status) is not None:
                continue
            self.mark_alive()
            with self._lock:
                if self._status is None:
                    self._suction = status.is_grab != 0.0
                    self._gripper = status.gripper
                self._status = status
                self.frames_received += 1
                self._wrote_since_status = False
                self._update_handles(status)
                # Showers 2016, second safeguard: the next command waits for the move before it
                if (
                    self._queue
                    and self.guard.stable
                    and (not self._inflight or self._queue[0].key == ("stop",))
                ):
                    self._send(self._queue.popleft())
        verdict = self.guard.verdict()
        if verdict is not None and self._connected:
            self.lose_link(f"link lost: {verdict}")

    def _doubt(self, status: codec.Status) -> str | None:
        """Why a decoded status frame is not believed (see StatusGuard), or None."""
        values = (status.x, status.y, status.z, status.r_head, status.paw)
        if not all(math.isfinite(v) and abs(v) < _FIELD_LIMIT for v in values):
            self.guard.refused("a Cartesian field is not a plausible number")
            return self.guard.last_reason
        if status.is_grab not in (0.0, 1.0) or not _GRIPPER[0] <= status.gripper <= _GRIPPER[1]:
            self.guard.refused(
                f"tool fields isGrab={status.is_grab:.4g}, gripper={status.gripper:.4g}"
            )
            return self.guard.last_reason
        return self.guard.check(status.joints, self._now if math.isfinite(self._now) else 0.0)

    def close(self) -> None:
        """Send a stop still waiting for its status frame (≤ 0.5 s, wall clock), then release the port.

        The rig stops the arm and closes it straight after; without the wait a stop
        queued behind this interval's command would never reach the arm.
        """
        deadline = time.monotonic() + 0.5
        # On a virtual clock nothing steps the emulator while closing: no frame would come.
        while self.connected and not self.clock.virtual and time.monotonic() < deadline:
            with self._lock:
                if not any(p.key == ("stop",) for p in self._queue):
                    break
            time.sleep(0.005)
        super().close()

    def _send_if_free(self) -> None:
        """Write the head of the queue now if this status interval has no command yet.

        At most one command goes out per status frame received, whether it is
        written when the frame arrives or, as here, when a behaviour asks and
        the interval is still free, so the firmware never drops one.
        """
        if (
            self._queue
            and self._status is not None
            and self.guard.stable
            and not self._wrote_since_status
            and not self._inflight
            and self._fault is None
        ):
            self._send(self._queue.popleft())

    def _send(self, item: _Pending) -> None:
        if not self.write(item.command.encode()):
            return
        self._wrote_since_status = True
        self.commands_written += 1
        self.remember_sent(item.key)
        if item.kind == "move" and item.handle is not None:
            target = item.target
            if target is None:  # move_joints queues every move with its target
                raise ValueError(f"a move without its target: {item.command}")
            start = np.array(self._status.joints) if self._status else target
            self._inflight.append((item.handle, start, target))
            item.handle.update(MotionStatus.RUNNING, 0.0)
        elif item.kind == "tool" and item.handle is not None and item.done_when is not None:
            self._tool_waits.append((item.handle, item.done_when))
            item.handle.update(MotionStatus.RUNNING)

    def _update_handles(self, status: codec.Status) -> None:
        q = np.array(status.joints)
        previous = self._previous
        still = previous is not None and (
            # equal lists are close; the list test spares np.allclose on a resting arm
            q.tolist() == previous.tolist() or np.allclose(q, previous, atol=1e-6)
        )
        self._previous = q
        while self._inflight:
            handle, start, target = self._inflight[0]
            if handle.done:
                self._inflight.popleft()
                continue
            span = float(np.max(np.abs(target - start)))
            left = float(np.max(np.abs(target - q)))
            if left <= self.tolerance and (still or span <= self.tolerance):
                handle.update(MotionStatus.DONE)
                self._inflight.popleft()
                continue
            if span > 0:
                handle.update(MotionStatus.RUNNING, 1.0 - left / span)
            break
        waits = []
        for handle, done_when in self._tool_waits:
            if done_when(status):
                handle.update(MotionStatus.DONE)
            elif not handle.done:
                waits.append((handle, done_when))
        self._tool_waits = waits

    # ------------------------------------------------------------------ ArmDriver

    def joints(self) -> np.ndarray:
        """Joint angles from the newest status frame, degrees (base, rear, fore)."""
        self.ensure_connected()
        status = self._status
        if status is None:
            return self.model.home.copy()
        return np.array(status.joints, dtype=float)

    @property
    def tool(self) -> ToolState:
        """Pump and gripper as reported by the arm."""
        status = self._status
        if status is None:
            return ToolState()
        return ToolState(suction=status.is_grab != 0.0, gripper=status.gripper)

    def move_joints(self, q: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Queue a state-6 MOVJ to ``q`` (degrees); refused targets send nothing."""
        description = f"move_joints {np.round(np.asarray(q, dtype=float), 3).tolist()}"
        try:
            q = self.checked_move(q, speed)
        except (HardwareFault, Unreachable) as exc:
            return self.refused(description, exc)
        target = np.asarray(np.float32(q), dtype=float)
        handle = self.track(MotionHandle(description, target))
        with self._lock:
            suction = self._suction
            key = ("move", tuple(target.tolist()), suction, self._gripper)
            here = np.array(self._status.joints) if self._status else None
            there = here is not None and float(np.max(np.abs(here - target))) <= self.tolerance
            if self.is_duplicate(key) and not self._queue and (self._inflight or there):
                # Showers 2016, third safeguard: do not re-send the same angles while the arm
                # is going there or is there (if it was moved away since, send again)
                start = here if here is not None else target
                self._inflight.append((handle, start, target))
                handle.update(MotionStatus.RUNNING)
                return handle
            if abs(speed - self._speed) > 1e-9:
                self._speed = speed
                config = codec.set_speed(speed * 100.0, 100.0)
                self._queue.append(_Pending(config, None, ("speed", speed), "config"))
            command = codec.move_joints(
                target, suction=suction, mode=codec.MODE_MOVJ, gripper=self._gripper
            )
            self._queue.append(_Pending(command, handle, key, "move", target=target))
            self._last_target = target
            self._send_if_free()
        return handle

    def set_suction(self, on: bool) -> MotionHandle:
        """Switch the pump with a jog frame (axis 9 / 10); DONE when the status shows it."""
        handle = self.track(MotionHandle(f"suction {'on' if on else 'off'}"))
        fault = self.ensure_connected()
        if fault is not None:
            handle.update(MotionStatus.FAILED, error=fault)
            return handle
        with self._lock:
            status = self._status
            if (
                self._suction == on
                and not any(p.kind == "tool" for p in self._queue)
                and status is not None
                and (status.is_grab != 0.0) == on
            ):
                handle.update(MotionStatus.DONE)
                return handle
            self._suction = on
            command = codec.jog(codec.AXIS_GRAB if on else codec.AXIS_RELEASE)

            def done_when(st: codec.Status) -> bool:
                return (st.is_grab != 0.0) == on

            self._queue.append(
                _Pending(command, handle, ("suction", on), "tool", done_when=done_when)
            )
            self._send_if_free()
        return handle

    def set_gripper(self, opening: float) -> MotionHandle:
        """Set the gripper servo angle (degrees, -90..90) with a state-6 frame at the last target."""
        handle = self.track(MotionHandle(f"gripper {opening}"))
        if not (isinstance(opening, (int, float)) and math.isfinite(opening)) or not (
            -90.0 <= opening <= 90.0
        ):
            handle.update(
                MotionStatus.FAILED,
                error=Unreachable(f"gripper angle {opening!r} is not within -90..90 degrees"),
            )
            return handle
        fault = self.ensure_connected()
        if fault is not None:
            handle.update(MotionStatus.FAILED, error=fault)
            return handle
        opening = float(np.float32(opening))
        with self._lock:
            status = self._status
            if status is not None and abs(status.gripper - opening) < 1e-3:
                self._gripper = opening
                handle.update(MotionStatus.DONE)
                return handle
            self._gripper = opening
            if self._last_target is not None:
                target = self._last_target
            elif status is not None:
                target = np.array(status.joints)
            else:
                target = self.model.home
            command = codec.move_joints(
                target, suction=self._suction, mode=codec.MODE_MOVJ, gripper=opening
            )

            def done_when(st: codec.Status) -> bool:
                return abs(st.gripper - opening) < 1e-3

            key = ("move", tuple(np.asarray(target).tolist()), self._suction, opening)
            self._queue.append(_Pending(command, handle, key, "tool", done_when=done_when))
            self._send_if_free()
        return handle

    def home(self) -> MotionHandle:
        """Re-reference the arm: the model's home pose with the base at 0, a board reset, the pose again.

        DONE once the reset board, its rear-arm and forearm angles read from its
        accelerometers, has moved to the home pose (see :mod:`.homing`); the
        reset takes about 2 s. With the suction on, the reset would switch it
        off and drop what it holds: the arm only moves to the home pose and
        :attr:`homed` is False until a homing resets the board. Refused while a
        reset is under way.
        """
        target = home_pose(self.model.home)
        homing = self._homing
        if homing is not None and homing.phase is Phase.BOOT:
            return self.refused(
                "home", HardwareFault("the board is still booting from its reset", self.device)
            )
        if homing is not None:
            homing.stop()  # a homing asked for again starts over
        reset = not self._suction
        move = self.move_joints(target)
        if move.status is MotionStatus.FAILED:
            return self.refused("home", move.error or Unreachable("home pose refused"))
        if reset:
            handle = MotionHandle("home: base to 0, then reset the board", target)
        else:
            handle = MotionHandle(
                "home pose only: the suction is on and a reset would drop what it holds",
                target,
            )
        handle.update(MotionStatus.RUNNING, 0.0)
        self._referenced = reset
        self._homing = BoardResetHoming(self, handle, move, target, reset=reset)
        return handle

    @property
    def homed(self) -> bool:
        """False after a :meth:`home` that could not reset the board (the suction was on)."""
        return self._referenced

    def step(self, now: float) -> None:
        """Once per tick on the run's thread: carry a homing forward (nothing otherwise)."""
        homing = self._homing
        if homing is None:
            return
        homing.step(now)
        if homing.phase is Phase.OVER:
            self._homing = None

    def stop(self) -> None:
        """Drop queued commands, mark motions STOPPED and send a jog stop (axis 0) at once.

        If a command already went out since the last status frame, the stop goes
        with the next status frame instead (≤ one status period), because the
        firmware would drop it.
        """
        with self._lock:
            self._queue = collections.deque(p for p in self._queue if p.kind == "tool")
            self._inflight.clear()
            self.remember_sent(None)
            stop = _Pending(codec.jog(codec.AXIS_STOP), None, ("stop",), "config")
            if self._ser is not None and self._fault is None and not self._wrote_since_status:
                self._send(stop)
            else:
                self._queue.appendleft(stop)
        for handle in self.active_handles():
            if handle.description.startswith("move"):
                handle.update(MotionStatus.STOPPED)
        homing = self._homing
        if homing is not None:
            homing.stop()
