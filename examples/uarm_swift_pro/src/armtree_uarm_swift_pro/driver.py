"""The uArm Swift Pro driver: firmware V4's G-code dialect over pyserial, never blocking a tick.

Connecting: ``P2201`` must answer ``SwiftPro`` (firmware 3.x, Marlin-based,
answers ``VSwiftPro`` and times moves differently: it is refused with what to
do), ``P2203`` a version 4.x, ``P2234`` power ``V1``; then ``M2400 S<mode>``
sets the work mode whose tool offsets the kinematic model uses.

Moving: the host checks every target against the model (limits, the arms'
angle, reach) before a byte is sent, then sends ``G0 X Y Z F`` for the tool
point of the target joints; the firmware answers a G or M command only when the
arm is idle again, so the move's ``$n ok`` marks it DONE and ``E22`` / ``E27``
fail it with the reason. At most two G/M commands are unanswered at a time (the
SDK's default); more wait on the host. The joints are polled with ``P2200``
(answered at once, from the encoders) every ``poll_period`` seconds. ``stop()``
sends ``S1100``, which the firmware acts on at once.

Units: mm and degrees; ``F`` is the firmware's speed (one unit is 80 degrees of
joint motion per minute; ``speed=1`` sends ``max_feed``).
"""

from __future__ import annotations

import collections
import math
import threading
from collections.abc import Callable

import numpy as np
from armtree.api.rig import MotionHandle, MotionStatus, ToolState
from armtree.errors import HardwareFault, Unreachable
from armtree.plugins.arms.common import LineParser, SerialArmDriver

from . import protocol as P
from .kinematics import SwiftProModel

#: G and M commands left unanswered at once (uArm SDK's cmd_pend_size default).
MAX_PENDING = 2
#: Banner lines and stray text kept for messages.
MAX_KEPT = 64


class SwiftProDriver(SerialArmDriver):
    """A uArm Swift Pro on firmware V4.x at 115200 8N1, real or emulated."""

    protocol = "uArm Swift Pro firmware V4 replies ('$n ok')"

    def __init__(
        self,
        model: SwiftProModel,
        port: str,
        *,
        max_feed: float = 75.0,
        poll_period: float = 0.05,
        query_timeout: float = 1.0,
        **options,
    ) -> None:
        options.setdefault("baud", 115200)
        options.setdefault("link_timeout", 1.0)
        options.setdefault("connect_timeout", 5.0)
        super().__init__(model, port, **options)
        self.model: SwiftProModel = model
        self.max_feed = max_feed
        self.poll_period = poll_period
        self.query_timeout = query_timeout
        self.banner: list[str] = []
        #: The firmware version the arm reported (``4.10.0``).
        self.firmware = ""
        self._lines = LineParser(max_line=256)
        self._lock = threading.RLock()
        self._number = 0
        self._waiting: dict[int, tuple[Callable[[P.Reply], None], bool, float]] = {}
        self._held: collections.deque[tuple[str, Callable[[P.Reply], None]]] = collections.deque()
        self._ready = False
        self._joints = np.asarray(model.home, dtype=float).copy()
        self._pump = False
        self._motions: list[MotionHandle] = []
        self._polling = False
        self._next_poll = -math.inf

    # ------------------------------------------------------------------ SerialArmDriver hooks

    def on_open(self) -> None:
        """Start the handshake: device type, firmware version, power, work mode."""
        with self._lock:
            self._waiting.clear()
            self._held.clear()
            self._ready = False
        self._send("P2201", self._on_device)

    def handshake_done(self) -> bool:
        """True once the arm has passed every check of the handshake."""
        return self._ready

    def on_data(self, data: bytes) -> None:
        """Route replies to their commands, events and banner lines aside (I/O thread)."""
        for raw in self._lines.feed(data):
            line = raw.strip()
            if not line:
                continue
            reply = P.parse_reply(line)
            if reply is not None:
                self._on_reply(reply)
            elif line.startswith("@"):
                self.mark_alive()
            elif "buffer full" in line:
                self.lose_link(f"the arm's command queue overflowed ({line!r})")
            elif len(self.banner) < MAX_KEPT:
                self.banner.append(line)

    def on_time(self, now: float) -> None:
        """Poll the joints; forget a query whose reply was lost (I/O thread)."""
        with self._lock:
            for n, (_, queued, sent) in list(self._waiting.items()):
                if not queued and now - sent > self.query_timeout:
                    del self._waiting[n]  # a lost reply to a query: the next poll asks again
                    self._polling = False
        if self._ready and not self._polling and now >= self._next_poll:
            self._next_poll = now + self.poll_period
            self._polling = True
            self._send("P2200", self._on_joints)

    # ------------------------------------------------------------------ traffic

    def _send(self, text: str, on_reply: Callable[[P.Reply], None]) -> None:
        """Number and send ``text``; a G or M command beyond MAX_PENDING waits its turn."""
        queued = text[0] in "GM"
        with self._lock:
            if queued and sum(q for _, q, _ in self._waiting.values()) >= MAX_PENDING:
                self._held.append((text, on_reply))
                return
            self._number = P.next_number(self._number)
            n = self._number
            now = self._now if math.isfinite(self._now) else self.clock.now()
            self._waiting[n] = (on_reply, queued, now)
        self.write(P.command(n, text).encode("ascii"))

    def _on_reply(self, reply: P.Reply) -> None:
        self.mark_alive()
        with self._lock:
            entry = self._waiting.pop(reply.number, None)
            held = self._held.popleft() if entry and entry[1] and self._held else None
        if entry is not None:
            entry[0](reply)
        if held is not None:
            self._send(*held)

    # ------------------------------------------------------------------ handshake

    def _on_device(self, reply: P.Reply) -> None:
        name = reply.text()
        if reply.ok and name == "SwiftPro":
            self._send("P2203", self._on_version)
        elif reply.ok and name == "VSwiftPro":
            self.lose_link(
                "this Swift Pro runs firmware 3.x (Marlin), which answers moves before they end; "
                "flash firmware 4.x (uArm Studio's firmware update) to use it with armtree"
            )
        else:
            self.lose_link(f"not a uArm Swift Pro: P2201 answered {name or reply.status!r}")

    def _on_version(self, reply: P.Reply) -> None:
        version = reply.text().lstrip("vV")
        major = version.split(".")[0]
        if not (reply.ok and major.isdigit() and int(major) >= 4):
            self.lose_link(f"firmware {version or '?'}: this driver speaks firmware 4.x")
            return
        self.firmware = version
        self._send("P2234", self._on_power)

    def _on_power(self, reply: P.Reply) -> None:
        if reply.value("V") != 1:
            self.lose_link("no power (P2234 V0): plug the 12 V supply into the base")
            return
        self._send(f"M2400 S{self.model.mode}", self._on_mode)

    def _on_mode(self, reply: P.Reply) -> None:
        if not reply.ok:
            self.lose_link(f"the arm refused work mode {self.model.mode} ({reply.status})")
            return
        self._send("P2200", self._on_first_joints)

    def _on_first_joints(self, reply: P.Reply) -> None:
        self._on_joints(reply)
        self._ready = True

    def _on_joints(self, reply: P.Reply) -> None:
        self._polling = False
        values = [reply.value(letter) for letter in "BLR"]
        if not reply.ok or any(v is None for v in values):
            self.lose_link(f"unreadable joint report: {reply}")
            return
        self._joints = np.array(values, dtype=float)

    # ------------------------------------------------------------------ ArmDriver

    def joints(self) -> np.ndarray:
        """``(base, left, right)`` degrees, as the encoders last reported them."""
        return self._joints.copy()

    @property
    def tool(self) -> ToolState:
        """The pump as last acknowledged."""
        return ToolState(suction=self._pump)

    def busy(self) -> bool:
        """True while a move or a pump command is unanswered."""
        with self._lock:
            return any(not h.done for h in self._motions)

    def _finished(self, handle: MotionHandle, what: str) -> Callable[[P.Reply], None]:
        def on_reply(reply: P.Reply) -> None:
            if reply.ok:
                handle.update(MotionStatus.DONE)
            elif reply.status == "E22":
                handle.update(
                    MotionStatus.FAILED, error=Unreachable(f"uArm: {what}: E22 {P.ERRORS['E22']}")
                )
            else:
                meaning = P.ERRORS.get(reply.status, "no error code")
                error = HardwareFault(f"{what}: {reply.status or '?'} {meaning}", self.device)
                handle.update(MotionStatus.FAILED, error=error)

        return on_reply

    def move_joints(self, q: np.ndarray, speed: float = 1.0) -> MotionHandle:
        """Move to joints ``q`` (degrees): G0 to its tool point; DONE with the firmware's ok."""
        description = f"move joints {np.round(np.asarray(q, dtype=float), 2).tolist()}"
        try:
            goal = self.checked_move(q, speed)
        except (Unreachable, HardwareFault) as exc:
            return self.refused(description, exc)
        x, y, z = self.model.position(goal)
        feed = P.number(max(1.0, self.max_feed * float(speed)))
        handle = self.track(MotionHandle(description, goal))
        handle.update(MotionStatus.RUNNING)
        with self._lock:
            self._motions = [h for h in self._motions if not h.done] + [handle]
        self._send(
            f"G0 X{P.number(x)} Y{P.number(y)} Z{P.number(z)} F{feed}",
            self._finished(handle, description),
        )
        return handle

    def set_suction(self, on: bool) -> MotionHandle:
        """Pump on or off (M2231); it acts at once, its ok comes once the arm is idle."""
        fault = self.ensure_connected()
        if fault is not None:
            return self.refused("suction", fault)
        handle = self.track(MotionHandle(f"suction {'on' if on else 'off'}"))
        done = self._finished(handle, "pump")

        def on_reply(reply: P.Reply) -> None:
            if reply.ok:
                self._pump = bool(on)
            done(reply)

        self._send(f"M2231 V{int(bool(on))}", on_reply)
        return handle

    def stop(self) -> None:
        """S1100: the firmware stops the arm and empties its queue; the pump stays as it is."""
        with self._lock:
            self._held.clear()
            for n in [n for n, (_, queued, _) in self._waiting.items() if queued]:
                del self._waiting[n]  # dropped by the firmware: no reply will come
        self.stop_all()
        if self._ser is not None and self._ready:
            self._send("S1100", lambda reply: None)
