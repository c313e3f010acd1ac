"""The Dobot V1.0 driver for the open-dobot firmware, over pyserial.

One request in flight at a time, its reply's CRC checked as a continuation
of the request's. The host plans every move itself (a synchronised trapezoid
on the joints' speeds) and streams it as one STEPS entry per 20 ms slot,
keeping the firmware's queue a few slots ahead; progress and completion come
from the step counters the firmware reports (GET_COUNTERS, polled at 50 Hz).
At connect the start-up pose is read from the accelerometers and written to
the counters, as open-dobot's SDK does. ``stop()`` sends EMERGENCY_STOP ahead
of everything else. ``calibrate_joint`` runs the limit-switch routine.
"""

from __future__ import annotations

import collections
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from armtree.api.rig import MotionHandle, MotionStatus, ToolState
from armtree.errors import HardwareFault, Unreachable

from ..common import JointMove, SerialArmDriver
from ..common.plausibility import StatusGuard
from . import opendobot as od

#: Slots kept queued ahead of the firmware (0.2 s).
SLOTS_AHEAD = 10
#: Run-clock seconds a reply may take before the request is sent again.
REPLY_TIMEOUT = 0.2
#: Unanswered requests in a row after which the link is lost.
MAX_RETRIES = 3
#: Requests that queue something, so that sending them twice would do it twice.
NOT_IDEMPOTENT = (od.STEPS, od.PUMP_ON, od.VALVE_ON, od.LASER_ON)


@dataclass
class _Request:
    """One request, what to do with its reply payload, and the handle it serves."""

    cmd: int
    payload: bytes = b""
    on_reply: Callable[[bytes], None] | None = None
    frame: bytes = b""
    crc: int = 0
    sent_at: float = -math.inf
    tries: int = 0


@dataclass
class _Plan:
    """A move being streamed: its handle, and its start and target step counters."""

    handle: MotionHandle
    start: np.ndarray
    target: np.ndarray


class OpenDobotDriver(SerialArmDriver):
    """Drives a Dobot V1.0 running open-dobot (angles in degrees, positions mm)."""

    protocol = "open-dobot replies (CRC-16/CCITT)"

    def __init__(self, *args, board: str = "fpga", **kwargs) -> None:
        super().__init__(*args, **kwargs)
        #: Doubts the joint angles the step counters give (finite, limits, speed).
        self.guard = StatusGuard(self.model)
        self.board = od.BOARDS[board]
        self._lock = threading.RLock()
        self._requests: collections.deque[_Request] = collections.deque()
        self._inflight: _Request | None = None
        self._rx = bytearray()
        self._counters: np.ndarray | None = None
        self._planned = np.zeros(3, dtype=np.int64)
        self._previous_counters: np.ndarray | None = None
        self._stream: collections.deque = collections.deque()
        self._plans: collections.deque[_Plan] = collections.deque()
        self._slots_ahead = 0.0
        self._last_time = -math.inf
        self._next_poll = -math.inf
        self._ready = False
        self._suction = False
        self._grab_pwm = 480
        self._rot_pwm = 0
        self._calibration: dict | None = None
        #: Requests sent and replies accepted, for figures and tests.
        self.requests_sent = 0
        self.replies_ok = 0
        #: Replies that failed their CRC.
        self.bad_replies = 0

    # ------------------------------------------------------------------ requests

    def _queue_request(self, req: _Request, first: bool = False) -> None:
        req.frame, req.crc = od.request(req.cmd, req.payload)
        with self._lock:
            if first:
                self._requests.appendleft(req)
            else:
                self._requests.append(req)
            if self._inflight is None:
                self._send_next()

    def _send_next(self) -> None:
        if self._inflight is not None or not self._requests:
            return
        req = self._requests.popleft()
        self._inflight = req
        self._rx.clear()
        req.sent_at = self.now if math.isfinite(self.now) else -math.inf
        req.tries += 1
        self.requests_sent += 1
        if not self.write(req.frame):
            self._inflight = None

    def on_open(self) -> None:
        """Handshake: BOARD_VERSION, accelerometers, then the counters from them."""
        with self._lock:
            self._requests.clear()
            self._inflight = None
            self._rx.clear()
            self._ready = False
            self._counters = None
        self._queue_request(_Request(od.BOARD_VERSION, on_reply=self._on_board))

    def _on_board(self, payload: bytes) -> None:
        if payload[0] != self.board.version:
            self.lose_link(
                f"wrong board: expected open-dobot on {self.board.name}, it reports "
                f"{'RAMPS' if payload[0] else 'FPGA'} (set arm.board)"
            )
            return
        self._queue_request(_Request(od.GET_ACCELS, on_reply=self._on_accels))

    def _on_accels(self, payload: bytes) -> None:
        rear_x, rear_y, rear_z, front_x, front_y, front_z = od.parse_accels(payload)
        if self.board is od.FPGA:
            # open-dobot SDK InitializeAccelerometers (open-dobot SDK)
            rear = math.pi / 2 - od.accel_to_radians(rear_x)
            front = od.accel_to_radians(front_x)
        else:
            rear = math.pi / 2 - math.atan2(rear_x, math.hypot(rear_y, rear_z))
            front = -math.atan2(front_x, math.hypot(front_y, front_z))
        counts = (
            0,
            round(rear / (2 * math.pi) * od.STEPS_PER_REV),
            round(front / (2 * math.pi) * od.STEPS_PER_REV),
        )
        self._planned = np.array(counts, dtype=np.int64)
        self._queue_request(
            _Request(od.SET_COUNTERS, od.counters_payload(*counts), on_reply=lambda p: self._poll())
        )

    def _poll(self) -> None:
        self._queue_request(_Request(od.GET_COUNTERS, on_reply=self._on_counters))

    def handshake_done(self) -> bool:
        """Connected once the counters are set from the accelerometers and read back."""
        return self._ready

    def on_data(self, data: bytes) -> None:
        """Collect the reply of the request in flight; check its CRC; act on it."""
        with self._lock:
            req = self._inflight
            if req is None:
                return  # the firmware never speaks unasked: noise
            self._rx.extend(data)
            need = od.REPLY_LEN[req.cmd]
            if need is None or len(self._rx) < need + 2:
                return
            frame = bytes(self._rx[: need + 2])
            self._rx.clear()
            payload = od.check_reply(frame, req.crc)
            if payload is None:
                self._inflight = None
                self.bad_replies += 1
                # Counted with the readings: a link of mostly corrupt replies is lost, not
                # asked again for ever (on a virtual clock that would all be one instant).
                self.guard.refused(f"a reply to command {req.cmd} that fails its CRC")
                verdict = self.guard.verdict()
                if verdict is not None:
                    self.lose_link(f"link lost: {verdict}")
                    return
                if req.cmd not in NOT_IDEMPOTENT:
                    # a corrupted reply: ask again (DobotDriver.reset() does the same)
                    self._requests.appendleft(req)
                # A queued command was most likely taken: sending it again could run it
                # twice; a wrong guess is corrected from the counters when the move settles.
                self._send_next()
                return
            self._inflight = None
            self.replies_ok += 1
            self.mark_alive()
        if req.on_reply is not None:
            req.on_reply(payload)
        with self._lock:
            self._send_next()

    def on_time(self, now: float) -> None:
        """Retries, the 50 Hz counter poll and topping up the firmware's step queue."""
        with self._lock:
            if math.isfinite(self._last_time):
                self._slots_ahead = max(0.0, self._slots_ahead - (now - self._last_time) / od.SLOT)
            self._last_time = now
            req = self._inflight
            if req is not None and math.isfinite(req.sent_at) and now - req.sent_at > REPLY_TIMEOUT:
                # While connecting, keep asking: the board resets when the port opens and
                # boots for about 2 s (open-dobot's driver retries BOARD_VERSION 200 times).
                if req.tries >= MAX_RETRIES and self._ready:
                    self.lose_link(
                        f"link lost: no open-dobot reply to command {req.cmd} after {req.tries} tries"
                    )
                    return
                self._inflight = None
                self._requests.appendleft(req)
                self._send_next()
            elif req is not None and not math.isfinite(req.sent_at):
                req.sent_at = now
            if not self._ready:
                return
            self._feed_stream()
            if now >= self._next_poll and not any(r.cmd == od.GET_COUNTERS for r in self._requests):
                self._next_poll = now + od.SLOT
                if self._inflight is None or self._inflight.cmd != od.GET_COUNTERS:
                    self._poll()
            self._calibration_tick()

    def _feed_stream(self) -> None:
        while self._stream and self._slots_ahead < SLOTS_AHEAD:
            item = self._stream[0]
            if item[0] == "wait":
                # Showers 2016, second safeguard: a move starts once the one before has finished
                if not item[1].done:
                    return
                self._stream.popleft()
                continue
            self._stream.popleft()
            if item[0] == "steps":
                self._slots_ahead += 1
                self._queue_request(_Request(od.STEPS, item[1], on_reply=self._steps_reply(item)))
            else:
                _, cmd, value, handle = item
                self._queue_request(
                    _Request(cmd, bytes([value]), on_reply=self._action_reply(item, handle))
                )

    def _steps_reply(self, item: tuple) -> Callable[[bytes], None]:
        def done(payload: bytes) -> None:
            if payload[0] != 1:  # queue full: the same slot again, first
                self._slots_ahead = SLOTS_AHEAD
                self._stream.appendleft(item)

        return done

    def _action_reply(self, item: tuple, handle: MotionHandle | None) -> Callable[[bytes], None]:
        def done(payload: bytes) -> None:
            if payload[0] != 1:
                self._stream.appendleft(item)
            elif handle is not None and item[1] == od.VALVE_ON:
                handle.update(MotionStatus.DONE)

        return done

    def _on_counters(self, payload: bytes) -> None:
        counters = np.array(od.parse_counters(payload), dtype=np.int64)
        # The CRC catches damage on the wire, not a board whose counters make no sense.
        q = counters.astype(float) / od.STEPS_PER_DEG
        if self.guard.check(q, self._now if math.isfinite(self._now) else 0.0) is not None:
            return
        with self._lock:
            self._counters = counters
            if not self._ready:
                self._planned = counters.copy()
                self._ready = True
            while self._plans:
                plan = self._plans[0]
                if plan.handle.done:
                    self._plans.popleft()
                    continue
                span = float(np.max(np.abs(plan.target - plan.start)))
                left = float(np.max(np.abs(plan.target - counters)))
                if left == 0:
                    plan.handle.update(MotionStatus.DONE)
                    self._plans.popleft()
                    continue
                if span > 0:
                    plan.handle.update(MotionStatus.RUNNING, 1.0 - max(0.0, left / span))
                if self._settled(counters):
                    # every slot ran but the counters missed the target (a lost or
                    # doubled slot): stream the difference
                    self._slot_plan(_Plan(plan.handle, counters.copy(), plan.target), 0.5)
                break
            self._previous_counters = counters

    # ------------------------------------------------------------------ ArmDriver

    def joints(self) -> np.ndarray:
        """Joint angles from the newest step counters, degrees (base, rear, fore)."""
        self.ensure_connected()
        counters = self._counters
        if counters is None:
            return self.model.home.copy()
        return counters.astype(float) / od.STEPS_PER_DEG

    @property
    def tool(self) -> ToolState:
        """Suction as last commanded and acknowledged (the firmware cannot report it)."""
        return ToolState(suction=self._suction)

    def move_joints(self, q: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Plan a synchronised move to ``q`` (degrees) and stream it slot by slot."""
        description = f"move_joints {np.round(np.asarray(q, dtype=float), 3).tolist()}"
        try:
            q = self.checked_move(q, speed)
        except (HardwareFault, Unreachable) as exc:
            return self.refused(description, exc)
        handle = self.track(MotionHandle(description, q))
        with self._lock:
            start = self._planned.copy()
            target = np.round(q * od.STEPS_PER_DEG).astype(np.int64)
            if self.is_duplicate(("move", tuple(target))) and np.array_equal(start, target):
                handle.update(MotionStatus.DONE)
                return handle
            plan = _Plan(handle, start, target)
            if self._plans:
                self._stream.append(("wait", self._plans[-1].handle))
            self._slot_plan(plan, speed)
            self._plans.append(plan)
            self.remember_sent(("move", tuple(target)))
            handle.update(MotionStatus.RUNNING, 0.0)
            self._feed_stream()
        return handle

    def _settled(self, counters: np.ndarray) -> bool:
        """True when nothing is left to stream and the counters stopped changing."""
        previous = self._previous_counters
        return (
            previous is not None
            and np.array_equal(previous, counters)
            and not any(item[0] == "steps" for item in self._stream)
            and not any(r.cmd == od.STEPS for r in self._requests)
            and (self._inflight is None or self._inflight.cmd != od.STEPS)
            and self._slots_ahead < 1.0
        )

    def _slot_plan(self, plan: _Plan, speed: float) -> None:
        spd = od.STEPS_PER_DEG
        move = JointMove(
            plan.start / spd,
            plan.target / spd,
            0.0,
            np.array([j.max_speed for j in self.model.joints]),
            np.array([j.max_accel for j in self.model.joints]),
            speed,
        )
        n = max(1, math.ceil(move.end_time / od.SLOT))
        counts = plan.start.copy()
        for k in range(1, n + 1):
            want = (
                plan.target
                if k == n
                else np.round(move.position(k * od.SLOT) * spd).astype(np.int64)
            )
            delta = want - counts
            steps, dirs = [], []
            for j in range(3):
                d = int(delta[j])
                # the forearm counter runs against its direction bit (open-dobot firmware)
                forward = d > 0 if j != 2 else d < 0
                n_req = abs(d)
                n_done = self._encodable(n_req)
                steps.append(n_done)
                dirs.append(int(forward))
                counts[j] += int(math.copysign(n_done, d)) if d else 0
            payload = od.steps_payload(
                self.board,
                (steps[0], steps[1], steps[2]),
                (dirs[0], dirs[1], dirs[2]),
                self._grab_pwm,
                self._rot_pwm,
            )
            self._stream.append(("steps", payload))
        # steps that the encoding could not make in their slot go in extra slots
        while not np.array_equal(counts, plan.target):
            delta = plan.target - counts
            steps = [self._encodable(abs(int(d))) for d in delta]
            dirs = [int(d > 0) if j != 2 else int(d < 0) for j, d in enumerate(delta)]
            for j in range(3):
                counts[j] += int(math.copysign(steps[j], int(delta[j]))) if delta[j] else 0
            payload = od.steps_payload(
                self.board,
                (steps[0], steps[1], steps[2]),
                (dirs[0], dirs[1], dirs[2]),
                self._grab_pwm,
                self._rot_pwm,
            )
            self._stream.append(("steps", payload))
        self._planned = plan.target.copy()

    def _encodable(self, n: int) -> int:
        """The largest step count <= ``n`` the board's encoding makes exactly in one slot."""
        if n <= 0:
            return 0
        coeff = self.board.step_coeff
        n = min(n, coeff)
        while n > 0 and coeff // max(1, coeff // n) != n:
            n -= 1
        return n

    def set_suction(self, on: bool) -> MotionHandle:
        """Pump on and valve closed (or pump off and valve open), queued after the moves."""
        handle = self.track(MotionHandle(f"suction {'on' if on else 'off'}"))
        fault = self.ensure_connected()
        if fault is not None:
            handle.update(MotionStatus.FAILED, error=fault)
            return handle
        with self._lock:
            self._suction = on
            handle.update(MotionStatus.RUNNING)
            self._stream.append(("action", od.PUMP_ON, int(on), None))
            self._stream.append(("action", od.VALVE_ON, int(not on), handle))
            self._feed_stream()
        return handle

    def stop(self) -> None:
        """EMERGENCY_STOP ahead of every other request; streamed moves are dropped."""
        with self._lock:
            self._stream = collections.deque(i for i in self._stream if i[0] == "action")
            self._plans.clear()
            self._requests = collections.deque(r for r in self._requests if r.cmd != od.STEPS)
            self._slots_ahead = 0.0
            self._calibration = None
            self.remember_sent(None)
            if self._ser is not None and self._fault is None:
                self._queue_request(
                    _Request(od.EMERGENCY_STOP, on_reply=lambda p: self._resync()), first=True
                )
        for handle in self.active_handles():
            if not handle.description.startswith("suction"):
                handle.update(MotionStatus.STOPPED)

    def _resync(self) -> None:
        def adopt(payload: bytes) -> None:
            self._on_counters(payload)
            with self._lock:
                # no counters yet when the board's reply was refused: keep the plan
                if self._counters is not None:
                    self._planned = self._counters.copy()

        self._queue_request(_Request(od.GET_COUNTERS, on_reply=adopt), first=True)

    # ------------------------------------------------------------------ limit switches

    def calibrate_joint(
        self,
        joint: int,
        switch_angle: float,
        *,
        toward_positive: bool = True,
        forward_hz: float = 1000.0,
        back_hz: float = 50.0,
        pin: int = 5,
        pullup: bool = False,
        normal_high: bool = True,
    ) -> MotionHandle:
        """Run the limit-switch routine on ``joint`` (0-2) and set its counter to ``switch_angle``.

        The joint moves toward the switch at ``forward_hz`` steps/s until it is hit,
        backs off at ``back_hz`` until released, and stops (open-dobot firmware, calibrator.cpp); the
        handle is DONE once the counter holds the switch's angle (degrees).
        """
        handle = self.track(MotionHandle(f"calibrate joint {joint}"))
        fault = self.ensure_connected()
        if fault is not None:
            handle.update(MotionStatus.FAILED, error=fault)
            return handle
        if joint not in (0, 1, 2):
            handle.update(MotionStatus.FAILED, error=Unreachable(f"joint {joint} is not 0, 1 or 2"))
            return handle
        toward = int(toward_positive) if joint != 2 else int(not toward_positive)
        payload = od.calibrate_payload(
            self.board.freq_value(forward_hz),
            self.board.freq_value(back_hz),
            pin,
            joint,
            toward,
            pullup,
            normal_high,
        )
        with self._lock:
            self._stream.clear()
            self._plans.clear()
            self._calibration = {
                "joint": joint,
                "angle": switch_angle,
                "handle": handle,
                "state": "start",
            }
            handle.update(MotionStatus.RUNNING)
            self._queue_request(
                _Request(od.CALIBRATE_JOINT, payload, on_reply=self._calibration_started)
            )
        return handle

    def _calibration_started(self, payload: bytes) -> None:
        if self._calibration is not None:
            self._calibration["state"] = "running"

    def _calibration_tick(self) -> None:
        c = self._calibration
        if c is None or c["state"] != "running" or self.now < c.get("next_poll", -math.inf):
            return
        # polled once per slot on the run clock, never in a loop within one instant
        c["next_poll"] = self.now + od.SLOT
        c["state"] = "polling"

        def status(payload: bytes) -> None:
            if self._calibration is not c:
                return
            if payload[0] != 0:
                c["state"] = "running"
                return
            counters = self._counters.copy() if self._counters is not None else self._planned.copy()
            counters[c["joint"]] = round(c["angle"] * od.STEPS_PER_DEG)
            self._planned = counters.copy()

            def finished(_: bytes) -> None:
                self._calibration = None
                c["handle"].update(MotionStatus.DONE)
                self._poll()

            self._queue_request(
                _Request(
                    od.SET_COUNTERS, od.counters_payload(*counters.tolist()), on_reply=finished
                )
            )

        self._queue_request(_Request(od.CALIBRATOR_STATUS, on_reply=status))
