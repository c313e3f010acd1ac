"""Timed joint trajectories: cubic and quintic polynomials through waypoints.

Pozzani 2023 (section 4.2, eq. 2) joins two configurations with a cubic
``q(t) = a3 t^3 + a2 t^2 + a1 t + a0`` whose coefficients solve the linear
system of the end positions and velocities; armtree adds the quintic (end
accelerations too), via-points with continuous velocity (the usual heuristic:
the mean of the neighbouring slopes, zero where the direction turns), segment
durations from per-joint velocity and acceleration limits, sampling for drivers
that take waypoints, and validation along the timed path (limits, speeds,
collisions, and the Jacobian's smallest singular value, Pozzani 2023 validatePath).

Units: joints in degrees (revolute) or mm (prismatic), time in seconds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from armtree.errors import PlanningError

from .collision import CollisionChecker
from .validation import PathReport, validate_samples


def cubic_coefficients(
    q0: np.ndarray,
    q1: np.ndarray,
    t_s: float,
    t_f: float,
    v0: np.ndarray | float = 0.0,
    v1: np.ndarray | float = 0.0,
) -> np.ndarray:
    """Coefficients ``(4, n)`` ``[a0, a1, a2, a3]`` of Pozzani 2023 eq. 2 on ``[t_s, t_f]`` (absolute time).

    Solves ``q(t_s) = q0, q(t_f) = q1, q'(t_s) = v0, q'(t_f) = v1`` as Pozzani 2023 does.
    """
    m = np.array(
        [
            [1, t_s, t_s**2, t_s**3],
            [1, t_f, t_f**2, t_f**3],
            [0, 1, 2 * t_s, 3 * t_s**2],
            [0, 1, 2 * t_f, 3 * t_f**2],
        ],
        dtype=float,
    )
    q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
    rhs = np.stack(
        np.broadcast_arrays(q0, q1, np.broadcast_to(v0, q0.shape), np.broadcast_to(v1, q0.shape))
    )
    return np.linalg.solve(m, rhs)


def quintic_coefficients(
    q0: np.ndarray,
    q1: np.ndarray,
    duration: float,
    v0: np.ndarray | float = 0.0,
    v1: np.ndarray | float = 0.0,
    a0: np.ndarray | float = 0.0,
    a1: np.ndarray | float = 0.0,
) -> np.ndarray:
    """Coefficients ``(6, n)`` in local time ``0..duration`` matching positions, velocities, accelerations."""
    t = float(duration)
    m = np.array(
        [
            [1, 0, 0, 0, 0, 0],
            [0, 1, 0, 0, 0, 0],
            [0, 0, 2, 0, 0, 0],
            [1, t, t**2, t**3, t**4, t**5],
            [0, 1, 2 * t, 3 * t**2, 4 * t**3, 5 * t**4],
            [0, 0, 2, 6 * t, 12 * t**2, 20 * t**3],
        ],
        dtype=float,
    )
    q0 = np.asarray(q0, dtype=float)
    b = [np.broadcast_to(np.asarray(x, dtype=float), q0.shape) for x in (q0, v0, a0, q1, v1, a1)]
    return np.linalg.solve(m, np.stack(b))


@dataclass
class Trajectory:
    """Piecewise polynomial joint trajectory.

    ``times`` ``(S + 1,)`` are the segment boundaries (s, starting at 0);
    ``coeffs[s]`` ``(k + 1, n)`` holds segment ``s``'s polynomial in local time
    ``t - times[s]``, lowest power first.
    """

    times: np.ndarray
    coeffs: list[np.ndarray]

    @property
    def duration(self) -> float:
        """Total time, s."""
        return float(self.times[-1])

    @property
    def waypoints(self) -> np.ndarray:
        """The configurations at the segment boundaries, ``(S + 1, n)``."""
        return self.position(self.times)

    def _eval(self, seg: int | np.ndarray, tau: np.ndarray | float, order: int) -> np.ndarray:
        segs = np.atleast_1d(seg)
        tau = np.atleast_1d(np.asarray(tau, dtype=float))
        out = np.zeros((len(tau), self.coeffs[0].shape[1]))
        if len(segs) == 1:
            # one time (a streamed set point): nothing to sort into segments
            groups: list[tuple[np.integer, slice | np.ndarray]] = [(segs[0], slice(None))]
        else:
            groups = [(s, segs == s) for s in np.unique(segs)]
        for s, sel in groups:
            c = self.coeffs[int(s)]
            # one gather and one scatter per segment, not one per power
            t = tau[sel, None]
            acc = np.zeros((len(t), out.shape[1]))
            for p in range(order, len(c)):
                fac = math.prod(range(p - order + 1, p + 1)) if order else 1.0
                acc += fac * c[p] * t ** (p - order)
            out[sel] = acc
        return out

    def _locate(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """The segment of each time ``t`` (clamped to the trajectory) and the time into it."""
        t = np.clip(np.atleast_1d(np.asarray(t, dtype=float)), 0.0, self.duration)
        seg = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.coeffs) - 1)
        return seg, t - self.times[seg]

    def position(self, t: np.ndarray | float) -> np.ndarray:
        """Joint positions at time(s) ``t`` (clamped to the trajectory), ``(..., n)``."""
        seg, tau = self._locate(t)
        out = self._eval(seg, tau, 0)
        return out.reshape(np.shape(t) + (out.shape[-1],))

    def velocity(self, t: np.ndarray | float) -> np.ndarray:
        """Joint velocities (deg/s or mm/s) at time(s) ``t``."""
        seg, tau = self._locate(t)
        out = self._eval(seg, tau, 1)
        return out.reshape(np.shape(t) + (out.shape[-1],))

    def acceleration(self, t: np.ndarray | float) -> np.ndarray:
        """Joint accelerations (deg/s^2 or mm/s^2) at time(s) ``t``."""
        seg, tau = self._locate(t)
        out = self._eval(seg, tau, 2)
        return out.reshape(np.shape(t) + (out.shape[-1],))

    def then(self, other: Trajectory) -> Trajectory:
        """This trajectory followed by ``other`` (which starts where this one ends, at rest)."""
        if other.duration <= 0.0:
            return self
        if self.duration <= 0.0:
            return other
        times = np.concatenate([self.times, self.duration + other.times[1:]])
        return Trajectory(times, [*self.coeffs, *other.coeffs])

    def sample(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Times ``(K,)`` every ``dt`` s (the end included) and the positions ``(K, n)`` there."""
        if not dt > 0:
            raise ValueError(f"sample period must be > 0 s, got {dt}")
        t = np.arange(0.0, self.duration, dt)
        t = np.append(t, self.duration)
        return t, self.position(t)


def via_velocities(waypoints: np.ndarray, durations: np.ndarray) -> np.ndarray:
    """Velocities ``(S + 1, n)`` at the waypoints: zero at the ends, the mean of the
    neighbouring slopes at a via-point, zero where a joint turns back."""
    slopes = np.diff(waypoints, axis=0) / durations[:, None]
    v = np.zeros_like(waypoints)
    same = np.sign(slopes[:-1]) == np.sign(slopes[1:])
    v[1:-1] = np.where(same, 0.5 * (slopes[:-1] + slopes[1:]), 0.0)
    return v


def _build(waypoints: np.ndarray, durations: np.ndarray, kind: str) -> Trajectory:
    v = via_velocities(waypoints, durations)
    times = np.concatenate([[0.0], np.cumsum(durations)])
    coeffs = []
    for s, d in enumerate(durations):
        if kind == "cubic":
            coeffs.append(
                cubic_coefficients(waypoints[s], waypoints[s + 1], 0.0, d, v[s], v[s + 1])
            )
        else:
            coeffs.append(quintic_coefficients(waypoints[s], waypoints[s + 1], d, v[s], v[s + 1]))
    return Trajectory(times, coeffs)


def _peaks(traj: Trajectory, samples: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Per segment and joint, the largest |velocity| and |acceleration| ``(S, n)`` each."""
    tau = np.linspace(0.0, 1.0, samples)
    vmax, amax = [], []
    for s, c in enumerate(traj.coeffs):
        d = traj.times[s + 1] - traj.times[s]
        t = tau * d
        powers = np.arange(len(c))
        vel = sum(p * c[p] * t[:, None] ** (p - 1) for p in powers[1:])
        acc = sum(p * (p - 1) * c[p] * t[:, None] ** (p - 2) for p in powers[2:])
        vmax.append(np.abs(vel).max(axis=0))
        amax.append(np.abs(acc).max(axis=0))
    return np.array(vmax), np.array(amax)


def plan_trajectory(
    waypoints: np.ndarray,
    kind: str = "cubic",
    durations: Sequence[float] | None = None,
    max_speed: np.ndarray | None = None,
    max_accel: np.ndarray | None = None,
) -> Trajectory:
    """A trajectory through ``waypoints`` ``(S + 1, n)`` (deg / mm), at rest at both ends.

    ``kind`` is ``"cubic"`` (Pozzani 2023 eq. 2) or ``"quintic"``. Give either the
    segment ``durations`` (s) or the per-joint limits ``max_speed`` (units/s)
    and ``max_accel`` (units/s^2): each segment then gets the shortest duration
    that keeps every joint within both, with continuous velocity at via-points.
    Repeated waypoints are merged.
    """
    if kind not in ("cubic", "quintic"):
        raise ValueError(f"trajectory kind must be 'cubic' or 'quintic', got {kind!r}")
    w = np.asarray(waypoints, dtype=float)
    if w.ndim != 2 or len(w) < 1 or not np.all(np.isfinite(w)):
        raise PlanningError("waypoints must be a finite (N, n) array", reason="not_finite")
    keep = np.concatenate([[True], np.any(np.abs(np.diff(w, axis=0)) > 1e-12, axis=1)])
    if durations is not None:
        d = np.asarray(durations, dtype=float)
        if len(d) != len(w) - 1 or np.any(~(d > 0)):
            raise ValueError(f"need {len(w) - 1} positive segment durations, got {list(d)}")
        d = d[keep[1:]]
        w = w[keep]
        if len(w) == 1:
            return Trajectory(np.array([0.0, 0.0]), [np.vstack([w[0], np.zeros((3, w.shape[1]))])])
        return _build(w, d, kind)
    w = w[keep]
    if len(w) == 1:
        return Trajectory(np.array([0.0, 0.0]), [np.vstack([w[0], np.zeros((3, w.shape[1]))])])
    if max_speed is None or max_accel is None:
        raise ValueError("give either durations or both max_speed and max_accel")
    vmax = np.broadcast_to(np.asarray(max_speed, dtype=float), w.shape[1:])
    amax = np.broadcast_to(np.asarray(max_accel, dtype=float), w.shape[1:])
    if np.any(~(vmax > 0)) or np.any(~(amax > 0)):
        raise ValueError("joint speed and acceleration limits must be > 0")
    delta = np.abs(np.diff(w, axis=0))
    # Rest-to-rest peaks: cubic 1.5 D/T and 6 D/T^2; quintic 1.875 D/T and 5.77 D/T^2.
    kv, ka = (1.5, 6.0) if kind == "cubic" else (1.875, 5.7735)
    d = np.maximum((kv * delta / vmax).max(axis=1), np.sqrt(ka * delta / amax).max(axis=1))
    d = np.maximum(d, 1e-6)
    for _ in range(50):
        traj = _build(w, d, kind)
        pv, pa = _peaks(traj)
        scale = np.maximum((pv / vmax).max(axis=1), np.sqrt((pa / amax).max(axis=1)))
        if np.all(scale <= 1.0 + 1e-6):
            return traj
        d = d * np.maximum(scale, 1.0) * (1.0 + 1e-9)
    return _build(w, d, kind)


def validate_trajectory(
    traj: Trajectory,
    checker: CollisionChecker,
    resolution: float = 1.0,
    min_singular: float | None = None,
    speed_tolerance: float = 1e-6,
    start_contact_mm: float = 0.0,
) -> PathReport:
    """Check a timed trajectory: limits, joint speeds, collisions, singularity margin.

    Samples in time so that no joint moves more than ``resolution`` (deg / mm)
    between samples, then checks each sample in order (Pozzani 2023, validatePath).
    Speeds above a joint's ``max_speed`` are reported as ``too_fast``. With
    ``start_contact_mm`` > 0 the trajectory may begin by leaving a contact at most
    that deep (mm) (:func:`~armtree.maths.motion.validation.validate_samples`).
    """
    model = checker.model
    pv, _ = _peaks(traj)
    speed = pv.max(axis=0) if len(pv) else np.zeros(model.dof)
    limit = np.array([j.max_speed for j in model.joints])
    over = speed > limit * (1 + speed_tolerance)
    if over.any():
        k = int(np.argmax(over))
        return PathReport(
            False,
            "too_fast",
            -1,
            f"joint {model.joints[k].name} reaches {speed[k]:.1f} {model.joints[k].unit}/s, "
            f"above its limit {limit[k]:g}",
        )
    peak = max(float(speed.max()), 1e-9)
    dt = max(resolution / peak, 1e-4)
    times, q = traj.sample(dt)
    return validate_samples(checker, q, min_singular, times, start_contact_mm)
