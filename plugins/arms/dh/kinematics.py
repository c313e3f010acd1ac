"""A serial arm described by a Denavit-Hartenberg table: batched FK, Jacobian and DLS IK.

Aceves slides gives the two conventions. Modified DH (Craig, "análisis por
articulaciones") builds link ``i`` from the previous frame as
``T = Rx(alpha_{i-1}) Dx(a_{i-1}) Rz(theta_i) Dz(d_i)`` (Aceves slides, the MaTran
function); standard DH as ``T = Rz(theta_i) Dz(d_i) Dx(a_i) Rx(alpha_i)``.
Table units at the edges are mm and degrees; the maths runs in radians and mm.

Speed: forward kinematics never builds 4x4 matrices per joint. The rotation
columns and the origin are kept as separate ``(N,)`` arrays and each joint
updates them with a handful of vector operations, so 100,000 configurations of
a 6-joint arm take a few tens of milliseconds (benchmarks/bench_kinematics.py).
"""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from armtree.errors import ConfigError, Unreachable
from armtree.maths.motion.kinematics import Joint, KinematicModel, LinkBox

from .planar import PlanarWrist

#: Configurations per block in batched FK: small enough for the temporaries to stay in cache.
_CHUNK = 2048
#: Iterations without a 0.1 % fall of the error after which an IK start is given up.
STALL = 8
#: Single-target IK answers kept for a repeated question.
RECENT = 8


@dataclass(frozen=True)
class DHRow:
    """One row of a DH table, mm and degrees.

    For ``convention="modified"`` ``a`` and ``alpha`` are ``a_{i-1}`` and
    ``alpha_{i-1}`` of Aceves slides; for ``"standard"`` they are ``a_i`` and
    ``alpha_i``. ``theta`` (revolute) or ``d`` (prismatic) is the joint's
    offset: the joint value is added to it.
    """

    a: float
    alpha: float
    d: float
    theta: float = 0.0
    kind: str = "revolute"
    #: Joint speed (deg/s or mm/s) and acceleration (per s^2) limits; None: the defaults.
    max_speed: float | None = None
    max_accel: float | None = None


def parse_dh(
    config: Mapping[str, Any], source: str = "<profile>"
) -> tuple[str, list[DHRow], list[tuple[float, float]]]:
    """Read ``{convention, table: [{a, alpha, d, theta, type, limits}]}`` from a profile.

    Returns the convention, the rows and each joint's (lower, upper) limits.
    Raises :class:`ConfigError` naming the row and field that is wrong.
    """
    convention = config.get("convention", "modified")
    if convention not in ("modified", "standard"):
        raise ConfigError(
            f"arm.dh.convention must be modified or standard, not {convention!r}", source
        )
    table = config.get("table")
    if not isinstance(table, Sequence) or isinstance(table, str) or not table:
        raise ConfigError("arm.dh.table must be a non-empty list of rows", source)
    rows: list[DHRow] = []
    limits: list[tuple[float, float]] = []
    for i, raw in enumerate(table):
        where = f"arm.dh.table[{i}]"
        if not isinstance(raw, Mapping):
            raise ConfigError(f"{where} must be a mapping with a, alpha, d, theta", source)
        unknown = set(raw) - {
            "a",
            "alpha",
            "d",
            "theta",
            "type",
            "limits",
            "name",
            "max_speed",
            "max_accel",
        }
        if unknown:
            raise ConfigError(f"{where}: unknown field(s) {sorted(unknown)}", source)
        values: dict[str, Any] = {}
        for key in ("a", "alpha", "d", "theta"):
            v = raw.get(key, 0.0)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
                raise ConfigError(f"{where}.{key} must be a finite number, got {v!r}", source)
            values[key] = float(v)
        for key in ("max_speed", "max_accel"):
            v = raw.get(key)
            if v is None:
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
                raise ConfigError(f"{where}.{key} must be a number > 0, got {v!r}", source)
            values[key] = float(v)
        kind = {
            "R": "revolute",
            "P": "prismatic",
            "revolute": "revolute",
            "prismatic": "prismatic",
        }.get(raw.get("type", "R"))
        if kind is None:
            raise ConfigError(f"{where}.type must be R or P, got {raw.get('type')!r}", source)
        lim = raw.get("limits", [-180.0, 180.0] if kind == "revolute" else [0.0, 100.0])
        if (
            not isinstance(lim, Sequence)
            or len(lim) != 2
            or not all(isinstance(v, (int, float)) and np.isfinite(v) for v in lim)
            or lim[0] >= lim[1]
        ):
            raise ConfigError(
                f"{where}.limits must be [lower, upper] with lower < upper, got {lim!r}", source
            )
        rows.append(DHRow(kind=kind, **values))
        limits.append((float(lim[0]), float(lim[1])))
    return convention, rows, limits


class DHModel(KinematicModel):
    """Any serial arm from a DH table (mm, degrees at the edges; radians inside).

    ``link_frames`` returns the base frame, one frame per joint and the tool
    centre point (``n + 2`` frames). ``ik_all`` takes ``(..., 4, 4)`` poses (6
    constraints) or ``(..., 3)`` positions and runs damped least squares from
    several seeds at once; each returned row is a distinct converged solution.

    ``tool_axis`` (a base-frame direction) makes position targets keep the
    tool's z axis along it: a hobby arm's wrist pitch holds the gripper
    vertical (``[0, 0, -1]``) while the other joints place it, as Aceves slides's
    arms are used. ``link_width`` is the least thickness (mm) of the link
    boxes drawn and checked for collisions; ``tool_boxes`` (in the last joint's
    frame) replace the box from the last joint to the tool centre, so an end
    effector can have its real shape (a gripper's palm above the fingertips,
    its fingers beside them).
    """

    def __init__(
        self,
        rows: Sequence[DHRow],
        limits: Sequence[tuple[float, float]],
        convention: str = "modified",
        name: str = "dh",
        tool_offset: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
        base: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
        home: Sequence[float] | np.ndarray | None = None,
        seeds: int = 12,
        seed: int = 0,
        link_width: float = 60.0,
        tool_axis: Sequence[float] | np.ndarray | None = None,
        tool_boxes: Sequence[LinkBox] = (),
    ) -> None:
        if convention not in ("modified", "standard"):
            raise ValueError(f"unknown DH convention {convention!r}")
        self.name = name
        self.convention = convention
        self.rows = tuple(rows)
        self.joints = tuple(
            Joint(
                f"q{i + 1}",
                r.kind,
                lo,
                hi,
                max_speed=r.max_speed or (90.0 if r.kind == "revolute" else 100.0),
                max_accel=r.max_accel or 360.0,
            )
            for i, (r, (lo, hi)) in enumerate(zip(self.rows, limits, strict=True))
        )
        self._a = np.array([r.a for r in self.rows])
        # exact 0 / +-1 for right-angle twists, so the chain can skip those products
        self._ca = _snap(np.cos(np.radians([r.alpha for r in self.rows])))
        self._sa = _snap(np.sin(np.radians([r.alpha for r in self.rows])))
        self._d = np.array([r.d for r in self.rows])
        self._theta = np.radians([r.theta for r in self.rows])
        self._revolute = np.array([r.kind == "revolute" for r in self.rows])
        self.tool_offset = np.asarray(tool_offset, dtype=float)
        self.base = np.asarray(base, dtype=float)
        self.tool_axis: np.ndarray | None = None
        if tool_axis is not None:
            axis = np.asarray(tool_axis, dtype=float)
            norm = float(np.linalg.norm(axis))
            if axis.shape != (3,) or not np.isfinite(norm) or norm < 1e-9:
                raise ValueError(f"tool_axis must be a non-zero [x, y, z], got {tool_axis!r}")
            self.tool_axis = axis / norm
        self.link_width = float(link_width)
        lo, hi = self.lower, self.upper
        self.home = np.clip(np.zeros(self.dof) if home is None else np.asarray(home, float), lo, hi)
        # Deterministic IK seeds: home first, then a fixed sample of the joint space.
        rng = np.random.default_rng(seed)
        self.seeds = np.vstack([self.home, rng.uniform(lo, hi, size=(max(seeds, 1) - 1, self.dof))])
        self._recent: dict[tuple, np.ndarray] = {}
        self._recent_lock = threading.Lock()
        #: Boxes of the end effector given in the profile (in the last joint's frame).
        self.tool_boxes = tuple(tool_boxes)
        self.boxes = self._make_boxes(self.link_width, self.tool_boxes)
        self.self_collision_pairs = self._collision_pairs()
        #: The closed form of a base-yaw, three-pitch arm holding ``tool_axis``, when this is one.
        self.planar = PlanarWrist.detect(self) if self.tool_axis is not None else None

    # ------------------------------------------------------------------ FK

    def _chain(self, q: np.ndarray, keep: bool) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """Run the chain on flattened ``(N, n)`` joints; returns rotation columns and origins.

        Each entry of the first list is ``(3, 3, N)`` (row, column, sample); of
        the second ``(3, N)``. With ``keep`` every joint frame is kept, else only
        the last one.
        """
        n_samples = q.shape[0]
        qr = q.T  # (n, N): one contiguous row per joint
        th = np.where(self._revolute[:, None], np.radians(qr), 0.0) + self._theta[:, None]
        dd = np.where(self._revolute[:, None], 0.0, qr) + self._d[:, None]
        cos_t, sin_t = np.cos(th), np.sin(th)
        # columns of R as (3, N) arrays; the base frame is the identity
        c0 = np.zeros((3, n_samples))
        c1 = np.zeros((3, n_samples))
        c2 = np.zeros((3, n_samples))
        c0[0] = c1[1] = c2[2] = 1.0
        p = np.zeros((3, n_samples)) + self.base[:, None]
        rots, origins = [], []
        modified = self.convention == "modified"
        for i in range(self.dof):
            ca, sa, a = self._ca[i], self._sa[i], self._a[i]
            ct, st, d = cos_t[i], sin_t[i], dd[i]
            if modified:
                # Aceves slides, MaTran: Rx(alpha_{i-1}) Dx(a_{i-1}) Rz(theta_i) Dz(d_i)
                if a:
                    p = p + a * c0
                b1, b2 = _twist(c1, c2, ca, sa)
                c0, c1, c2 = c0 * ct + b1 * st, b1 * ct - c0 * st, b2
                if not self._revolute[i] or self._d[i]:  # d = 0 on a revolute joint: no shift
                    p = p + b2 * d
            else:
                # standard DH: Rz(theta_i) Dz(d_i) Dx(a_i) Rx(alpha_i)
                if not self._revolute[i] or self._d[i]:
                    p = p + c2 * d
                n0 = c0 * ct + c1 * st
                m1 = c1 * ct - c0 * st
                if a:
                    p = p + n0 * a
                c1, c2 = _twist(m1, c2, ca, sa)
                c0 = n0
            if keep:
                rots.append(np.stack([c0, c1, c2], axis=1))
                origins.append(p)
        if not keep:
            rots.append(np.stack([c0, c1, c2], axis=1))
            origins.append(p)
        return rots, origins

    def _tool(self, R: np.ndarray, p: np.ndarray) -> np.ndarray:
        t = self.tool_offset
        return p + R[:, 0] * t[0] + R[:, 1] * t[1] + R[:, 2] * t[2]

    def _flat(self, q: np.ndarray) -> tuple[np.ndarray, tuple[int, ...]]:
        q = np.asarray(q, dtype=float)
        if q.shape[-1] != self.dof:
            raise ValueError(f"{self.name}: expected {self.dof} joints, got shape {q.shape}")
        return q.reshape(-1, self.dof), q.shape[:-1]

    def fk(self, q: np.ndarray) -> np.ndarray:
        """Tool pose ``(..., 4, 4)`` in mm for joints ``(..., n)`` in degrees / mm."""
        flat, lead = self._flat(q)
        out = np.zeros((flat.shape[0], 4, 4))
        out[:, 3, 3] = 1.0
        # chunks that stay in cache: the chain is a long run of elementwise operations
        for i in range(0, flat.shape[0], _CHUNK):
            rots, origins = self._chain(flat[i : i + _CHUNK], keep=False)
            R = rots[-1]
            out[i : i + _CHUNK, :3, :3] = np.moveaxis(R, -1, 0)
            out[i : i + _CHUNK, :3, 3] = self._tool(R, origins[-1]).T
        return out.reshape(*lead, 4, 4)

    def position(self, q: np.ndarray) -> np.ndarray:
        """Tool position ``(..., 3)`` in mm."""
        flat, lead = self._flat(q)
        out = np.empty((flat.shape[0], 3))
        for i in range(0, flat.shape[0], _CHUNK):
            rots, origins = self._chain(flat[i : i + _CHUNK], keep=False)
            out[i : i + _CHUNK] = self._tool(rots[-1], origins[-1]).T
        return out.reshape(*lead, 3)

    def link_frames(self, q: np.ndarray) -> np.ndarray:
        """Base frame, every joint frame and the tool frame: ``(..., n + 2, 4, 4)``, mm."""
        flat, lead = self._flat(q)
        rots, origins = self._chain(flat, keep=True)
        # Every frame is written straight into one array: the world asks for one pose a tick.
        out = np.zeros((flat.shape[0], self.dof + 2, 4, 4))
        out[:, :, 3, 3] = 1.0
        out[:, 0, :3, :3] = np.eye(3)
        out[:, 0, :3, 3] = self.base
        for k, (R, p) in enumerate(zip(rots, origins, strict=True), start=1):
            out[:, k, :3, :3] = np.moveaxis(R, -1, 0)
            out[:, k, :3, 3] = p.T
        out[:, -1, :3, :3] = out[:, -2, :3, :3]
        out[:, -1, :3, 3] = self._tool(rots[-1], origins[-1]).T
        return out.reshape(*lead, self.dof + 2, 4, 4)

    def _axes(
        self, rots: list[np.ndarray], origins: list[np.ndarray]
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Each joint's axis direction and a point on it, ``(3, N)`` each.

        Modified DH puts frame ``i`` on joint ``i``'s axis; standard DH moves
        joint ``i`` about the z axis of frame ``i - 1`` (the base for the first).
        """
        if self.convention == "modified":
            return [(R[:, 2], p) for R, p in zip(rots, origins, strict=True)]
        n = rots[0].shape[-1]
        base_z = np.zeros((3, n))
        base_z[2] = 1.0
        base_p = np.zeros((3, n)) + self.base[:, None]
        zs = [base_z] + [R[:, 2] for R in rots[:-1]]
        ps = [base_p] + origins[:-1]
        return list(zip(zs, ps, strict=True))

    def jacobian_geometric(self, q: np.ndarray) -> np.ndarray:
        """Geometric Jacobian ``(..., 6, n)``: mm per radian (or per mm) over rad per radian."""
        flat, lead = self._flat(q)
        rots, origins = self._chain(flat, keep=True)
        tip = self._tool(rots[-1], origins[-1])
        J = np.zeros((flat.shape[0], 6, self.dof))
        for i, (z, o) in enumerate(self._axes(rots, origins)):
            if self._revolute[i]:
                J[:, :3, i] = np.cross(z.T, (tip - o).T)
                J[:, 3:, i] = z.T
            else:
                J[:, :3, i] = z.T
        return J.reshape(*lead, 6, self.dof)

    # ------------------------------------------------------------------ IK

    def ik_all(
        self,
        target: np.ndarray,
        seeds: np.ndarray | None = None,
        tol: float = 1e-3,
        iterations: int = 100,
        orientation_weight: float = 200.0,
    ) -> np.ndarray:
        """Damped-least-squares IK from every seed at once: ``(..., S, n)``, NaN where a seed failed.

        ``target`` is ``(..., 4, 4)`` (position and orientation) or ``(..., 3)``
        (position only), mm. A seed counts as solved when the position error is
        below ``tol`` mm and the orientation error below ``tol / orientation_weight``
        rad, within the joint limits. Duplicate solutions (closer than 1e-3 deg)
        are reported once. ``orientation_weight`` (mm per radian) balances the
        two kinds of error in the damped step. The answers for the last few
        single targets are kept: a planner asks whether a target is reachable
        and then for its solutions, one call after the other. Position targets of
        an arm :attr:`planar` describes are solved in closed form instead
        (``(..., 4, n)``: two base turns by elbow up and down; its free joints,
        a wrist roll, keep the first seed's values).
        """
        target = np.asarray(target, dtype=float)
        key = None
        if target.size <= 16 and seeds is None:
            key = (target.shape, target.tobytes(), tol, iterations, orientation_weight)
            with self._recent_lock:
                if key in self._recent:
                    return self._recent[key].copy()
        out = self._ik_all(target, seeds, tol, iterations, orientation_weight)
        if key is not None:
            with self._recent_lock:
                self._recent[key] = out.copy()
                while len(self._recent) > RECENT:
                    del self._recent[next(iter(self._recent))]
        return out

    def _ik_all(
        self,
        target: np.ndarray,
        seeds: np.ndarray | None,
        tol: float,
        iterations: int,
        orientation_weight: float,
    ) -> np.ndarray:
        full = target.shape[-2:] == (4, 4)
        if not full and self.planar is not None and target.shape[-1] == 3:
            free = self.home if seeds is None else np.atleast_2d(seeds)[0]
            return self._closed_form(target, free)
        if not full and target.shape[-1] != 3:
            raise ValueError(
                f"{self.name}: target must be (..., 3) or (..., 4, 4), got {target.shape}"
            )
        lead = target.shape[:-2] if full else target.shape[:-1]
        flat_t = target.reshape(-1, 4, 4) if full else target.reshape(-1, 3)
        s = self.seeds if seeds is None else np.atleast_2d(np.asarray(seeds, dtype=float))
        n_t, n_s = flat_t.shape[0], s.shape[0]
        q = np.tile(s, (n_t, 1))  # (T*S, n)
        tgt = np.repeat(flat_t, n_s, axis=0)
        q, err = self._dls(q, tgt, full, tol, iterations, orientation_weight)
        ok = (err < tol) & self.within_limits(q)
        q = np.where(ok[:, None], q, np.nan).reshape(n_t, n_s, self.dof)
        q = self._dedupe(q)
        return q.reshape(*lead, n_s, self.dof)

    def ik_batch(
        self,
        target: np.ndarray,
        near: np.ndarray | None = None,
        tol: float = 1e-3,
        iterations: int = 25,
        orientation_weight: float = 200.0,
    ) -> np.ndarray:
        """One solution per target, ``(..., n)``; NaN rows where every start failed.

        Vectorised passes: every target starts from ``near`` (default: home);
        the failures are retried from the four starts of a fixed pool (the
        model's seeds and 64 more from a fixed generator, their poses computed
        once) whose poses are closest to the target, and what still fails from
        the rest of the pool, and last from 256 random starts with twice the
        iterations (rtb's ikine_LM also restarts at random). Same tolerances as
        :meth:`ik_all`; the first success in that order is kept.
        """
        target = np.asarray(target, dtype=float)
        full = target.shape[-2:] == (4, 4)
        lead = target.shape[:-2] if full else target.shape[:-1]
        if not full and self.planar is not None:
            ref = self.home if near is None else np.asarray(near, dtype=float)
            sols = self._closed_form(target.reshape(-1, 3), ref)
            dist = np.where(np.isfinite(sols).all(-1), np.abs(sols - ref).max(-1), np.inf)
            best = np.take_along_axis(sols, np.argmin(dist, axis=1)[:, None, None], axis=1)[:, 0]
            return best.reshape(*lead, self.dof)
        flat_t = target.reshape(-1, 4, 4) if full else target.reshape(-1, 3)
        pool, pool_T = self._start_pool()
        # closeness of every pool start to every target: position, plus orientation (chordal)
        t_pos = flat_t[:, :3, 3] if full else flat_t
        dist = np.linalg.norm(t_pos[:, None, :] - pool_T[None, :, :3, 3], axis=-1)
        if full:
            chord = np.linalg.norm(flat_t[:, None, :3, :3] - pool_T[None, :, :3, :3], axis=(-2, -1))
            dist = dist + orientation_weight * chord
        order = np.argsort(dist, axis=1)
        n_t = flat_t.shape[0]
        out = np.full((n_t, self.dof), np.nan)
        todo = np.arange(n_t)
        ref = self.home if near is None else np.asarray(near, dtype=float)
        first = np.broadcast_to(ref, (n_t, 1, self.dof))
        # last resort, as rtb's random restarts: 256 more starts and twice the iterations
        rng = np.random.default_rng(54321)
        extra = np.broadcast_to(
            rng.uniform(self.lower, self.upper, (256, self.dof)), (n_t, 256, self.dof)
        )
        plans = [
            (first, iterations),
            (pool[order[:, :4]], iterations),
            (pool[order[:, 4:]], iterations),
            (extra, 2 * iterations),
        ]
        for starts, its in plans:
            if todo.size == 0 or starts.shape[1] == 0:
                continue
            k = starts.shape[1]
            q = starts[todo].reshape(-1, self.dof).copy()
            tgt = np.repeat(flat_t[todo], k, axis=0)
            q, err = self._dls(q, tgt, full, tol, its, orientation_weight)
            ok = ((err < tol) & self.within_limits(q)).reshape(todo.size, k)
            per_start = q.reshape(todo.size, k, self.dof)
            found = ok.any(axis=1)
            out[todo[found]] = per_start[found, np.argmax(ok[found], axis=1)]
            todo = todo[~found]
        return out.reshape(*lead, self.dof)

    def _closed_form(self, target: np.ndarray, free: np.ndarray) -> np.ndarray:
        """:attr:`planar`'s solutions ``(..., 4, n)`` for positions ``(..., 3)``, each joint
        turned by a whole turn into its limits where that fits; NaN where none does."""
        assert self.planar is not None and self.tool_axis is not None
        lead = target.shape[:-1]
        q = self.planar.solve(target.reshape(-1, 3), self.tool_axis, np.asarray(free, float))
        turns = q[None] + np.array([0.0, 360.0, -360.0])[:, None, None, None]
        inside = (turns >= self.lower - 1e-9) & (turns <= self.upper + 1e-9)
        pick = np.argmax(inside, axis=0)
        q = np.take_along_axis(turns, pick[None], axis=0)[0]
        q = np.where(self.within_limits(q)[..., None], q, np.nan)
        return self._dedupe(q).reshape(*lead, q.shape[-2], self.dof)

    def _start_pool(self) -> tuple[np.ndarray, np.ndarray]:
        """IK starts (the seeds and 64 fixed random ones) and their tool poses, cached."""
        if getattr(self, "_pool", None) is None:
            rng = np.random.default_rng(12345)
            pool = np.vstack([self.seeds, rng.uniform(self.lower, self.upper, (64, self.dof))])
            self._pool = (pool, self.fk(pool))
        return self._pool

    def _errors(
        self, q: np.ndarray, tgt: np.ndarray, full: bool, w: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Error vectors ``(M, 6|3)`` (mm, weighted radians) and the Jacobian ``(M, 6|3, n)``.

        Position targets of a model with :attr:`tool_axis` get three more rows:
        ``w * (axis - z)``, the tool's z axis ``z`` pulled onto the wanted axis
        (zero only when they point the same way), with ``dz = omega x z``.
        """
        axis = not full and self.tool_axis is not None
        rots, origins = self._chain(q, keep=True)
        R = rots[-1]
        tip = self._tool(R, origins[-1])
        z_tool = R[:, 2]  # (3, M)
        deg = np.pi / 180.0
        axes = self._axes(rots, origins)
        axis_dirs = np.stack([z for z, _ in axes], axis=1)  # (3, n, M): every joint at once
        points = np.stack([o for _, o in axes], axis=1)
        revolute = self._revolute[None, :, None]
        # mm per degree for revolute joints (the chain takes degrees), mm per mm for prismatic
        rows = [np.where(revolute, _cross(axis_dirs, tip[:, None, :] - points) * deg, axis_dirs)]
        if full:
            rows.append(np.where(revolute, axis_dirs * (w * deg), 0.0))
        elif axis:
            rows.append(np.where(revolute, _cross(axis_dirs, z_tool[:, None, :]) * (w * deg), 0.0))
        J = np.concatenate(rows).transpose(2, 0, 1)  # (M, 3 | 6, n)
        e_pos = tgt[:, :3, 3] - tip.T if full else tgt - tip.T
        if axis:
            return np.concatenate([e_pos, w * (self.tool_axis - z_tool.T)], axis=1), J
        if not full:
            return e_pos, J
        Rc = np.moveaxis(R, -1, 0)  # (M, 3, 3)
        # orientation error: the rotation vector (axis * angle, radians) taking the current
        # orientation to the target, in the base frame; an exact log map, because near 180
        # degrees the usual sum of column cross products vanishes and would stall the solver
        local = _rotvec(np.swapaxes(Rc, 1, 2) @ tgt[:, :3, :3])
        e_rot = np.einsum("mij,mj->mi", Rc, local)
        return np.concatenate([e_pos, w * e_rot], axis=1), J

    def _dls(
        self, q: np.ndarray, tgt: np.ndarray, full: bool, tol: float, iterations: int, w: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Levenberg-style damped least squares, vectorised over problems; joints clamped to limits."""
        lo, hi = self.lower, self.upper
        lam = np.full(q.shape[0], 1.0)
        e, J = self._errors(q, tgt, full, w)
        cost = np.einsum("ij,ij->i", e, e)
        m = e.shape[1]
        eye = np.eye(m)
        active = np.ones(q.shape[0], dtype=bool)
        # a start stuck in a local minimum (often against a joint limit) stops early
        progress = np.zeros(q.shape[0], dtype=int)
        for k in range(iterations):
            idx = np.flatnonzero(active)
            if idx.size == 0:
                break
            Ja, ea = J[idx], e[idx]
            A = Ja @ np.swapaxes(Ja, 1, 2) + (lam[idx] ** 2)[:, None, None] * eye
            dq = np.einsum("mji,mj->mi", Ja, np.linalg.solve(A, ea[..., None])[..., 0])
            qn = np.clip(q[idx] + dq, lo, hi)
            en, Jn = self._errors(qn, tgt[idx], full, w)
            cn = np.einsum("ij,ij->i", en, en)
            better = cn < cost[idx]
            take = idx[better]
            progress[idx[cn < cost[idx] * (1.0 - 1e-3)]] = k
            q[take], e[take], J[take], cost[take] = qn[better], en[better], Jn[better], cn[better]
            lam[take] *= 0.5
            lam[idx[~better]] *= 4.0
            lam = np.clip(lam, 1e-4, 1e6)
            active[idx] = (
                (np.sqrt(cost[idx]) >= tol) & (lam[idx] < 1e6) & (k - progress[idx] < STALL)
            )
        return q, np.sqrt(cost)

    def _dedupe(self, q: np.ndarray) -> np.ndarray:
        """Blank (NaN) any solution that repeats an earlier one for the same target."""
        n_s = q.shape[1]
        for j in range(1, n_s):
            d = np.abs(q[:, :j, :] - q[:, j : j + 1, :]).max(axis=-1)
            dup = np.any(d < 1e-3, axis=1)
            q[dup, j, :] = np.nan
        return q

    def ik(self, target: np.ndarray, near: np.ndarray | None = None) -> np.ndarray:
        """One solution, nearest to ``near`` (which is also tried as a seed); raises Unreachable."""
        target = np.asarray(target, dtype=float)
        if not np.all(np.isfinite(target)):
            raise Unreachable(f"{self.name}: target {target.tolist()} is not finite")
        ref = (
            self.home
            if near is None
            else np.clip(np.asarray(near, dtype=float), self.lower, self.upper)
        )
        sols = self.ik_all(target, seeds=np.vstack([ref, self.seeds]))
        sols = sols[np.all(np.isfinite(sols), axis=-1)]
        if len(sols) == 0:
            shown = target[:3, 3] if target.shape == (4, 4) else target
            raise Unreachable(
                f"{self.name}: target {np.round(shown, 2).tolist()} mm is outside the workspace "
                "or the joint limits"
            )
        return sols[np.argmin(np.linalg.norm(sols - ref, axis=-1))]

    # ------------------------------------------------------------------ boxes

    def _collision_pairs(self) -> tuple[tuple[int, int], ...]:
        """Box pairs that can collide: not neighbours, and apart at the home pose.

        Boxes that already overlap at home (short wrist links sharing one
        point, a shoulder inside its own housing) are built that way, as an
        SRDF disables them; their bounding spheres are the conservative test.
        """
        centres = self.box_poses(self.home)[:, :3, 3]
        radii = 0.5 * np.linalg.norm(self.box_sizes(), axis=1)
        pairs = []
        for i in range(len(self.boxes)):
            for j in range(i + 2, len(self.boxes)):
                if np.linalg.norm(centres[i] - centres[j]) > radii[i] + radii[j]:
                    pairs.append((i, j))
        return tuple(pairs)

    def _make_boxes(self, width: float, tool: tuple[LinkBox, ...] = ()) -> tuple[LinkBox, ...]:
        """One box per link, spanning frame ``i``'s origin to frame ``i + 1``'s at home.

        The box is axis-aligned in frame ``i`` and at least ``width`` mm thick in
        every direction, so short links still have a volume. ``tool`` boxes, when
        given, stand for the last link (the end effector).
        """
        frames = self.link_frames(self.home)
        boxes = []
        for i in range(self.dof + (0 if tool else 1)):
            rel = np.linalg.inv(frames[i]) @ frames[i + 1][:, 3]
            sx, sy, sz = (float(max(abs(s), width)) for s in rel[:3])
            off = np.eye(4)
            off[:3, 3] = rel[:3] / 2
            boxes.append(LinkBox(f"link{i}", i, (sx, sy, sz), off))
        return (*boxes, *tool)


def _rotvec(R: np.ndarray) -> np.ndarray:
    """Rotation vectors (axis * angle, radians) of rotation matrices ``(M, 3, 3)``.

    Uses the skew part away from 180 degrees and the symmetric part near it,
    where the skew part vanishes.
    """
    cos = np.clip((R[:, 0, 0] + R[:, 1, 1] + R[:, 2, 2] - 1.0) * 0.5, -1.0, 1.0)
    angle = np.arccos(cos)
    v = np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], -1)
    sin = np.sin(angle)
    scale = np.where(sin > 1e-9, angle / np.maximum(2.0 * sin, 1e-300), 0.5)
    out = v * scale[:, None]
    near_pi = angle > np.pi - 1e-4
    if np.any(near_pi):
        B = (R[near_pi] + np.eye(3)) * 0.5  # ~ a a^T for a half turn about a
        k = np.argmax(np.diagonal(B, axis1=1, axis2=2), axis=1)
        rows = np.arange(len(k))
        axis = B[rows, :, k] / np.sqrt(np.maximum(B[rows, k, k], 1e-300))[:, None]
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        sign = np.where(np.einsum("mi,mi->m", axis, v[near_pi]) < 0, -1.0, 1.0)
        out[near_pi] = axis * (sign * angle[near_pi])[:, None]
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross products of the columns of two ``(3, M)`` arrays."""
    return np.stack(
        (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
    )


def _snap(values: np.ndarray) -> np.ndarray:
    """Round cosines and sines within 1e-12 of 0 or +-1 to those exact values."""
    out = np.asarray(values, dtype=float).copy()
    for exact in (0.0, 1.0, -1.0):
        out[np.abs(out - exact) < 1e-12] = exact
    return out


def _twist(c1: np.ndarray, c2: np.ndarray, ca: float, sa: float) -> tuple[np.ndarray, np.ndarray]:
    """Columns y and z after a rotation about x by alpha (cos ``ca``, sin ``sa``).

    Right-angle twists (the common case in DH tables) are a swap and a sign.
    """
    if sa == 0.0:
        return (c1, c2) if ca == 1.0 else (-c1, -c2)
    if ca == 0.0:
        return (c2, -c1) if sa == 1.0 else (-c2, c1)
    return c1 * ca + c2 * sa, c2 * ca - c1 * sa


def model_from_config(config: Mapping[str, Any], source: str = "<profile>") -> DHModel:
    """Build a :class:`DHModel` from a profile's ``arm`` mapping (its ``dh:`` section)."""
    dh = config.get("dh")
    if not isinstance(dh, Mapping):
        raise ConfigError(
            "a dh arm needs its DH table: arm.dh, a mapping with convention and table "
            "(e.g. the shipped profiles dh_puma560 and dh_motoman_l3)",
            source,
        )
    convention, rows, limits = parse_dh(dh, source)
    tool = dh.get("tool_offset_mm", config.get("tool_offset_mm", [0.0, 0.0, 0.0]))
    base = dh.get("base_mm", [0.0, 0.0, 0.0])
    for key, v in (("tool_offset_mm", tool), ("base_mm", base)):
        if not isinstance(v, Sequence) or len(v) != 3:
            raise ConfigError(f"arm.dh.{key} must be [x, y, z] in mm, got {v!r}", source)
    home = dh.get("home")
    if home is not None and (not isinstance(home, Sequence) or len(home) != len(rows)):
        raise ConfigError(f"arm.dh.home must list {len(rows)} joint values", source)
    axis = dh.get("tool_axis")
    if axis is not None and (
        not isinstance(axis, Sequence)
        or len(axis) != 3
        or not all(isinstance(v, (int, float)) and np.isfinite(v) for v in axis)
        or not np.any(np.asarray(axis, dtype=float))
    ):
        raise ConfigError(
            f"arm.dh.tool_axis must be a non-zero [x, y, z] direction, got {axis!r}", source
        )
    width = dh.get("link_width_mm", 60.0)
    if isinstance(width, bool) or not isinstance(width, (int, float)) or not width > 0:
        raise ConfigError(f"arm.dh.link_width_mm must be a number > 0, got {width!r}", source)
    tool_boxes = _tool_boxes(dh.get("tool_boxes_mm"), len(rows), source)
    return DHModel(
        rows,
        limits,
        convention,
        name=str(config.get("name", "dh")),
        tool_offset=tool,
        base=base,
        home=home,
        seeds=int(dh.get("ik_seeds", 12)),
        link_width=float(width),
        tool_axis=axis,
        tool_boxes=tool_boxes,
    )


def _tool_boxes(spec: Any, dof: int, source: str) -> tuple[LinkBox, ...]:
    """``arm.dh.tool_boxes_mm``: ``[{name, size: [x, y, z], center: [x, y, z]}]`` in the
    last joint's frame, as :class:`LinkBox` es on that frame."""
    if spec is None:
        return ()
    if not isinstance(spec, Sequence) or isinstance(spec, str) or not spec:
        raise ConfigError("arm.dh.tool_boxes_mm must be a list of {name, size, center}", source)
    out = []
    for k, item in enumerate(spec):
        where = f"arm.dh.tool_boxes_mm[{k}]"
        if not isinstance(item, Mapping) or set(item) - {"name", "size", "center"}:
            raise ConfigError(f"{where} must be a mapping of name, size and center", source)
        vectors = []
        for key, default in (("size", None), ("center", [0.0, 0.0, 0.0])):
            v = item.get(key, default)
            ok = (
                isinstance(v, Sequence)
                and len(v) == 3
                and all(isinstance(x, (int, float)) and np.isfinite(x) for x in v)
            )
            if not ok or (key == "size" and min(v) <= 0):
                raise ConfigError(f"{where}.{key} must be [x, y, z] in mm, got {v!r}", source)
            vectors.append([float(x) for x in v])
        offset = np.eye(4)
        offset[:3, 3] = vectors[1]
        name = str(item.get("name", f"tool{k}"))
        sx, sy, sz = vectors[0]  # three numbers: checked above
        out.append(LinkBox(name, dof, (sx, sy, sz), offset))
    return tuple(out)
