"""The Duckybot: a differential-drive robot following a route with Lyapunov tracking control.

The robot is a unicycle (Pozzani 2023, eqs. 5-6). A reference unicycle drives the
route at constant speeds (straight segments at ``speed``, turns on the spot at
``turn_rate``); the real one follows it with the Lyapunov control law of
Pozzani 2023, eqs. 7-8, under seeded actuator noise, so a tracker sees a robot that
moves smoothly but not exactly as planned. Positions are mm, headings radians
inside (degrees in the route), times seconds on the run's clock.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Leg:
    """One piece of the route.

    ``kind`` is ``"drive"`` (to ``target`` (x, y)), or ``"park"`` (drive to
    ``target`` and turn to ``heading``, then wait). A park ends when the
    Duckybot is loaded (``until == "loaded"``) and ``wait`` seconds have passed
    since, or after ``timeout`` seconds parked, or after ``wait`` seconds when
    ``until == "time"``.
    """

    kind: str
    target: tuple[float, float]
    heading: float | None = None
    until: str = "loaded"
    wait: float = 1.0
    timeout: float = math.inf


@dataclass
class UnicycleState:
    """Planar pose: x, y in mm, theta in radians."""

    x: float
    y: float
    theta: float

    def as_array(self) -> np.ndarray:
        """``[x, y, theta]``."""
        return np.array([self.x, self.y, self.theta])


def wrap(angle: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


def sinc(x: float) -> float:
    """Unnormalised sinc, sin(x)/x, 1 at 0."""
    return 1.0 if abs(x) < 1e-9 else math.sin(x) / x


def unicycle_step(state: UnicycleState, v: float, omega: float, dt: float) -> UnicycleState:
    """Integrate the unicycle model over ``dt`` seconds (Pozzani 2023, eqs. 5-6).

    x' = v cos(theta), y' = v sin(theta), theta' = omega; integrated exactly
    for constant (v, omega) over the step so turns on the spot stay in place.
    """
    th = state.theta
    if abs(omega) < 1e-9:
        return UnicycleState(state.x + v * math.cos(th) * dt, state.y + v * math.sin(th) * dt, th)
    th2 = th + omega * dt
    r = v / omega
    return UnicycleState(
        state.x + r * (math.sin(th2) - math.sin(th)),
        state.y - r * (math.cos(th2) - math.cos(th)),
        wrap(th2),
    )


def lyapunov_control(
    actual: UnicycleState,
    desired: UnicycleState,
    v_d: float,
    omega_d: float,
    kp: float,
    ktheta: float,
) -> tuple[float, float]:
    """Velocities (mm/s, rad/s) that make ``actual`` converge to ``desired``.

    Pozzani 2023, eqs. 7-8: v = v_d + dv, w = w_d + dw with
    dv = -kp e_xy cos(theta - psi) and
    dw = -v_d e_xy sinc(e_theta / 2) sin(psi - alpha / 2) - ktheta e_theta,
    where (e_x, e_y, e_theta) = actual - desired, psi = atan2(e_y, e_x),
    alpha = theta_a + theta_d. The report prints eq. 8 without the factor e_xy;
    it is restored here because the derivative of V = (e_x^2 + e_y^2 + e_theta^2) / 2
    only cancels with it (the cross term is v_d e_xy (cos(theta_a - psi) - cos(theta_d - psi))).
    """
    ex, ey = actual.x - desired.x, actual.y - desired.y
    e_theta = wrap(actual.theta - desired.theta)
    e_xy = math.hypot(ex, ey)
    psi = math.atan2(ey, ex)
    # alpha / 2 taken as the mean heading: desired + e_theta / 2 keeps it continuous across +-pi.
    half_alpha = desired.theta + 0.5 * e_theta
    dv = -kp * e_xy * math.cos(actual.theta - psi)  # Pozzani 2023, eq. 7
    dw = -v_d * e_xy * sinc(e_theta / 2) * math.sin(psi - half_alpha) - ktheta * e_theta  # eq. 8
    return v_d + dv, omega_d + dw


@dataclass
class DuckybotParams:
    """Speeds, gains, limits and noise of one Duckybot."""

    speed: float = 50.0  # mm/s along straight legs
    turn_rate: float = math.radians(90.0)  # rad/s turning on the spot
    kp: float = 2.0
    ktheta: float = 4.0
    max_speed: float = 120.0  # mm/s, the wheels' limit
    max_turn: float = math.radians(240.0)  # rad/s
    noise: float = 0.03  # relative actuator noise (standard deviation)
    park_tolerance: float = 3.0  # mm: close enough to call it parked
    settle_time: float = 3.0  # s: longest wait for the error to fall below park_tolerance
    dt: float = 0.01  # s, control period


@dataclass
class _Segment:
    """A reference motion at constant (v_d, omega_d) for ``duration`` seconds."""

    v: float
    omega: float
    duration: float


class Duckybot:
    """A Duckybot driving its route; :meth:`advance` integrates it to a time.

    ``loaded`` is called while parked to ask the world whether a ducky is on
    board. The reference and the actual pose are both exposed so tests can
    bound the tracking error.
    """

    def __init__(
        self,
        name: str,
        start: tuple[float, float, float],
        route: list[Leg],
        params: DuckybotParams,
        rng: np.random.Generator,
        loaded: Callable[[], bool] = lambda: False,
        loop: bool = False,
    ) -> None:
        self.name = name
        self.params = params
        self.route = list(route)
        self.loop = loop
        self.loaded = loaded
        self._rng = rng
        self.state = UnicycleState(start[0], start[1], start[2])
        self.reference = UnicycleState(start[0], start[1], start[2])
        self.time = 0.0
        self.leg_index = 0
        self.phase = "driving" if self.route else "done"
        self._segments: list[_Segment] = []
        self._parked_since: float | None = None
        self._loaded_since: float | None = None
        self._settle_since: float | None = None
        self.max_tracking_error = 0.0
        #: The last (v mm/s, omega rad/s) sent to the wheels.
        self.command = (0.0, 0.0)
        self.trail: list[tuple[float, float]] = [(start[0], start[1])]
        self._plan_leg()

    # -- reference trajectory -------------------------------------------------

    def _plan_leg(self) -> None:
        """Turn the current leg into constant-velocity reference segments."""
        self._segments = []
        if self.leg_index >= len(self.route):
            self.phase = "done"
            return
        leg = self.route[self.leg_index]
        p = self.params
        ref = self.reference
        dx, dy = leg.target[0] - ref.x, leg.target[1] - ref.y
        dist = math.hypot(dx, dy)
        heading = ref.theta
        if dist > 1e-6:
            heading = math.atan2(dy, dx)  # Pozzani 2023, eq. 3: face the goal, then drive (eq. 4)
            turn = wrap(heading - ref.theta)
            if abs(turn) > 1e-6:
                self._segments.append(
                    _Segment(0.0, math.copysign(p.turn_rate, turn), abs(turn) / p.turn_rate)
                )
            self._segments.append(_Segment(p.speed, 0.0, dist / p.speed))
        if leg.kind == "park" and leg.heading is not None:
            turn = wrap(leg.heading - heading)
            if abs(turn) > 1e-6:
                self._segments.append(
                    _Segment(0.0, math.copysign(p.turn_rate, turn), abs(turn) / p.turn_rate)
                )
        self.phase = "driving"

    def _next_leg(self) -> None:
        self.leg_index += 1
        if self.leg_index >= len(self.route) and self.loop and self.route:
            self.leg_index = 0
        self._parked_since = None
        self._loaded_since = None
        self._plan_leg()

    def _reference_step(self, dt: float) -> tuple[float, float]:
        """Advance the reference by ``dt`` and return the (v_d, omega_d) it used."""
        if not self._segments:
            return 0.0, 0.0
        seg = self._segments[0]
        used = min(dt, seg.duration)
        self.reference = unicycle_step(self.reference, seg.v, seg.omega, used)
        seg.duration -= used
        v, w = seg.v, seg.omega
        if seg.duration <= 1e-12:
            self._segments.pop(0)
            self._snap_reference()
        return v, w

    def _snap_reference(self) -> None:
        """Remove integration drift at the end of a leg so references hit targets exactly."""
        if self._segments or self.leg_index >= len(self.route):
            return
        leg = self.route[self.leg_index]
        theta = self.reference.theta if leg.heading is None or leg.kind != "park" else leg.heading
        self.reference = UnicycleState(leg.target[0], leg.target[1], wrap(theta))

    # -- simulation -------------------------------------------------------------

    @property
    def tracking_error(self) -> float:
        """Distance between the robot and its reference, mm."""
        return math.hypot(self.state.x - self.reference.x, self.state.y - self.reference.y)

    @property
    def parked(self) -> bool:
        """True while waiting at a parking spot."""
        return self.phase == "parked"

    def advance(self, now: float) -> None:
        """Integrate the robot up to ``now`` seconds in fixed control periods."""
        p = self.params
        while self.time + p.dt <= now + 1e-9:
            self._control_step(p.dt)
            self.time += p.dt

    def _control_step(self, dt: float) -> None:
        p = self.params
        if self.phase != "driving":
            # Parked or done: the motors are off, so a ducky placed on top stays where it lands.
            self.command = (0.0, 0.0)
            self._update_phase()
            return
        v_d, w_d = self._reference_step(dt)
        v, w = lyapunov_control(self.state, self.reference, v_d, w_d, p.kp, p.ktheta)
        # min and max of plain floats clip as np.clip does, at a fraction of its cost per call
        v = float(min(max(v, -p.max_speed), p.max_speed))
        w = float(min(max(w, -p.max_turn), p.max_turn))
        if p.noise > 0 and (abs(v) > 1e-6 or abs(w) > 1e-6):
            # Wheel slip: the robot does not execute its command exactly; the control corrects it.
            n_v, n_w = self._rng.standard_normal(2)
            v *= 1.0 + p.noise * float(n_v)
            w += p.noise * float(n_w)
        self.state = unicycle_step(self.state, v, w, dt)
        self.command = (v, w)
        self.max_tracking_error = max(self.max_tracking_error, self.tracking_error)
        last = self.trail[-1]
        if math.hypot(self.state.x - last[0], self.state.y - last[1]) > 2.0:
            self.trail.append((self.state.x, self.state.y))
        self._update_phase()

    def _update_phase(self) -> None:
        if self.phase == "driving" and not self._segments and self.leg_index < len(self.route):
            leg = self.route[self.leg_index]
            if leg.kind == "drive":
                self._next_leg()
                return
            if self._settle_since is None:
                self._settle_since = self.time
            # A unicycle cannot correct a sideways error standing still: park after a settling time.
            settled = self.time - self._settle_since >= self.params.settle_time
            if self.tracking_error <= self.params.park_tolerance or settled:
                self.phase = "parked"
                self._parked_since = self.time
                self._settle_since = None
        elif self.phase == "parked":
            leg = self.route[self.leg_index]
            assert self._parked_since is not None
            if leg.until == "loaded" and self._loaded_since is None and self.loaded():
                self._loaded_since = self.time
            waited = self.time - self._parked_since
            ready = (
                (leg.until == "time" and waited >= leg.wait)
                or (self._loaded_since is not None and self.time - self._loaded_since >= leg.wait)
                or waited >= leg.timeout
            )
            if ready:
                self._next_leg()


@dataclass
class RouteSpec:
    """A parsed route: start pose (x, y mm, heading rad), legs and options."""

    start: tuple[float, float, float]
    legs: list[Leg] = field(default_factory=list)
    loop: bool = False
