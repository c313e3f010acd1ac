"""Collision checking of an arm's link boxes against a :class:`~armtree.maths.motion.scene.Scene`.

The arm is the set of link boxes its :class:`~armtree.maths.motion.kinematics.KinematicModel`
places for a configuration (Showers 2016, eqs. 11-13: each link's box rotated by the
joints before it and offset by the preceding link lengths). A configuration
collides when a moving link box

* dips below the table plane (exact: the box's lowest corner),
* overlaps an obstacle box (exact separating-axis test over the 15 axes),
* touches a mesh triangle (bounding-box broad phase, then the box's 12 surface
  triangles against the mesh triangle with Moller's exact test, Showers 2016
  Algorithm 1, plus a mesh vertex inside the box for triangles swallowed whole),
* or overlaps a non-adjacent link box of the same arm (self-collision).

Everything is vectorised over configurations: ``collides(q)`` takes ``(n,)`` or
``(N, n)``. Units: degrees / mm for joints, mm for lengths. Touching within
``1e-6`` mm is not a collision.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

from armtree.errors import ConfigError

from .geometry import BOX_CORNER_SIGNS, BOX_TRIANGLES
from .kinematics import KinematicModel
from .scene import Scene
from .tritri import intersect_pairs

#: Contact closer than this (mm) is not a collision.
TOUCH_TOL = 1e-6


def obb_overlap(
    ca: np.ndarray,
    ra: np.ndarray,
    ha: np.ndarray,
    cb: np.ndarray,
    rb: np.ndarray,
    hb: np.ndarray,
    tol: float = TOUCH_TOL,
) -> np.ndarray:
    """Separating-axis test of oriented boxes, broadcast over leading axes.

    ``c*`` centres ``(..., 3)`` mm, ``r*`` rotations ``(..., 3, 3)`` (columns are
    the box axes), ``h*`` half sizes ``(..., 3)`` mm. True where the boxes overlap
    by more than ``tol``. Exact: the 3 + 3 face axes and the 9 edge-edge axes,
    after a bounding-sphere rejection; each stage runs only on the pairs the
    previous one left undecided.
    """
    ca, cb, ha, hb = (np.asarray(x, dtype=float) for x in (ca, cb, ha, hb))
    ra, rb = np.asarray(ra, dtype=float), np.asarray(rb, dtype=float)
    shape = np.broadcast_shapes(
        ca.shape[:-1], cb.shape[:-1], ha.shape[:-1], hb.shape[:-1], ra.shape[:-2], rb.shape[:-2]
    )
    if shape == ():
        return obb_overlap(ca[None], ra[None], ha[None], cb[None], rb[None], hb[None], tol)[0]
    d = cb - ca
    reach = np.linalg.norm(ha, axis=-1) + np.linalg.norm(hb, axis=-1)
    near = np.broadcast_to(np.einsum("...i,...i->...", d, d) < reach * reach, shape)
    out = np.zeros(shape, dtype=bool)
    idx = np.nonzero(near)
    if len(idx[0]) == 0:
        return out

    def pick(x: np.ndarray, tail: int) -> np.ndarray:
        return np.broadcast_to(x, shape + x.shape[x.ndim - tail :])[idx]

    ra_, rb_, ha_, hb_, d_ = pick(ra, 2), pick(rb, 2), pick(ha, 1), pick(hb, 1), pick(d, 1)
    hit = _sat(ra_, rb_, ha_, hb_, d_, tol)
    out[idx] = hit
    return out


def _sat(
    ra: np.ndarray, rb: np.ndarray, ha: np.ndarray, hb: np.ndarray, d: np.ndarray, tol: float
) -> np.ndarray:
    r = np.swapaxes(ra, 1, 2) @ rb
    t = np.einsum("mki,mk->mi", ra, d)
    # The bias keeps near-parallel edges (a cross product of ~0) from reporting a
    # false separation through rounding; those axes are then never separating.
    a = np.abs(r) + 1e-9
    sep = np.any(np.abs(t) > ha + np.einsum("mij,mj->mi", a, hb) - tol, axis=1)
    sep |= np.any(
        np.abs(np.einsum("mi,mij->mj", t, r)) > np.einsum("mi,mij->mj", ha, a) + hb - tol, axis=1
    )
    live = np.flatnonzero(~sep)
    if len(live) == 0:
        return ~sep
    r, t, a, ha, hb = r[live], t[live], a[live], ha[live], hb[live]
    cross_sep = np.zeros(len(live), dtype=bool)
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            ra_ = ha[:, i1] * a[:, i2, j] + ha[:, i2] * a[:, i1, j]
            rb_ = hb[:, j1] * a[:, i, j2] + hb[:, j2] * a[:, i, j1]
            cross_sep |= np.abs(t[:, i2] * r[:, i1, j] - t[:, i1] * r[:, i2, j]) > ra_ + rb_
    sep[live] = cross_sep
    return ~sep


@dataclass(frozen=True)
class Contact:
    """One reason a configuration collides: which link box hit what."""

    box: str
    other: str

    def __str__(self) -> str:
        return f"link box {self.box!r} hits {self.other}"


class CollisionChecker:
    """Collision queries for one arm model in one scene, batched over configurations.

    ``margin`` (mm) grows every moving link box on each side. Boxes that no joint
    moves (the base) are checked once here: an obstacle overlapping them is a
    :class:`~armtree.errors.ConfigError`. Self-collision pairs are the model's
    ``self_collision_pairs``, or else every pair of boxes on non-adjacent links
    that is apart at the home configuration.
    """

    def __init__(
        self,
        model: KinematicModel,
        scene: Scene,
        margin: float = 0.0,
        self_collision: bool = True,
        chunk: int = 4096,
    ) -> None:
        self.model = model
        self.scene = scene
        self.margin = float(margin)
        self.chunk = int(chunk)
        self.names = [b.name for b in model.boxes]
        half = 0.5 * model.box_sizes()
        if len(half) == 0:
            raise ConfigError(f"arm model {model.name!r} has no link boxes to check for collisions")
        probes = _probe_configs(model)
        poses = model.box_poses(probes)
        fixed = np.all(np.abs(poses - poses[:1]) < 1e-9, axis=(0, 2, 3))
        self.moving = np.flatnonzero(~fixed)
        self.fixed = np.flatnonzero(fixed)
        # The margin is clearance around what moves; the base keeps its true size
        # (it stands on the table).
        self.half = half.copy()
        self.half[self.moving] += self.margin
        self.half_moving = self.half[self.moving]
        # Boxes offset from their link frame by a translation only (and a model that
        # keeps the generic box_poses) get their poses without 4x4 products.
        offsets = np.array([b.offset for b in model.boxes], dtype=float)
        self._translated = type(model).box_poses is KinematicModel.box_poses and np.allclose(
            offsets[:, :3, :3], np.eye(3)
        )
        self._links = np.array([b.link for b in model.boxes])
        self._offsets = offsets[:, :3, 3]
        self._boxes = _obstacle_arrays(scene)
        self._aligned = [bool(np.allclose(r, np.eye(3))) for r in self._boxes[1]]
        self._mesh = _mesh_arrays(scene)
        self.pairs = self._self_pairs(self_collision) if len(self.moving) else np.zeros((0, 2), int)
        self._check_fixed(poses[0])

    # -- set-up ---------------------------------------------------------------

    def _self_pairs(self, enabled: bool) -> np.ndarray:
        if not enabled:
            return np.zeros((0, 2), dtype=int)
        if self.model.self_collision_pairs:
            return np.array(self.model.self_collision_pairs, dtype=int).reshape(-1, 2)
        links = np.array([b.link for b in self.model.boxes])
        n = len(links)
        cand = np.array(
            [(i, j) for i in range(n) for j in range(i + 1, n) if abs(links[i] - links[j]) >= 2],
            dtype=int,
        ).reshape(-1, 2)
        cand = cand[~(np.isin(cand[:, 0], self.fixed) & np.isin(cand[:, 1], self.fixed))]
        if len(cand) == 0:
            return cand
        home = self.model.box_poses(np.asarray(self.model.home, dtype=float))
        touching = obb_overlap(
            home[cand[:, 0], :3, 3], home[cand[:, 0], :3, :3], self.half[cand[:, 0]],
            home[cand[:, 1], :3, 3], home[cand[:, 1], :3, :3], self.half[cand[:, 1]],
        )  # fmt: skip
        # Boxes that already overlap at home are modelled as touching parts, not a collision.
        return cand[~touching]

    def _check_fixed(self, poses: np.ndarray) -> None:
        for b in self.fixed:
            for other in self._hits(poses[None, b : b + 1], self.half[None, b : b + 1], fixed=True):
                raise ConfigError(
                    f"{other} overlaps the arm's fixed part {self.names[b]!r}: "
                    "move the obstacle away from the arm's base",
                    file=self.scene.source,
                )

    # -- queries ----------------------------------------------------------------

    def collides(self, q: np.ndarray) -> bool | np.ndarray:
        """True where configuration(s) ``q`` ``(n,)`` or ``(N, n)`` (deg / mm) collide."""
        q = np.asarray(q, dtype=float)
        flat = q.reshape(-1, self.model.dof)
        out = np.empty(len(flat), dtype=bool)
        for s in range(0, len(flat), self.chunk):
            out[s : s + self.chunk] = self._collides(flat[s : s + self.chunk])
        return bool(out[0]) if q.ndim == 1 else out.reshape(q.shape[:-1])

    def valid(self, q: np.ndarray) -> bool | np.ndarray:
        """True where ``q`` is finite, within the joint limits and constraints, and collision-free."""
        q = np.asarray(q, dtype=float)
        ok = np.asarray(self.model.within_limits(q))
        flat_ok = ok.reshape(-1)
        flat_q = q.reshape(-1, self.model.dof)
        result = flat_ok.copy()
        if flat_ok.any():
            result[flat_ok] = ~np.atleast_1d(self.collides(flat_q[flat_ok]))
        return bool(result[0]) if q.ndim == 1 else result.reshape(q.shape[:-1])

    def contacts(self, q: np.ndarray) -> list[Contact]:
        """Every contact of one configuration ``q`` (deg / mm), for messages."""
        q = np.asarray(q, dtype=float).reshape(1, -1)
        poses = self.model.box_poses(q)
        out = [
            Contact(self.names[self.moving[k]], other)
            for k, b in enumerate(self.moving)
            for other in self._hits(poses[:, b : b + 1], self.half[None, b : b + 1])
        ]
        if len(self.pairs):
            hit = self._self_hits(poses)[0]
            out += [
                Contact(self.names[i], f"link box {self.names[j]!r} (self-collision)")
                for (i, j), h in zip(self.pairs, hit, strict=True)
                if h
            ]
        return out

    def segments_free(
        self, q0: np.ndarray, q1: np.ndarray, step: float = 2.0, ends: bool = True
    ) -> np.ndarray:
        """Boolean ``(E,)``: is each straight joint-space segment ``q0[e] -> q1[e]`` valid?

        Each segment is sampled so consecutive samples differ by at most ``step``
        (degrees for revolute, mm for prismatic joints) in every joint, and every
        sample must be within limits and collision-free. ``ends=False`` skips the
        end points (a roadmap has checked its nodes already). All samples of all
        segments are checked in one batch.
        """
        q0 = np.atleast_2d(np.asarray(q0, dtype=float))
        q1 = np.atleast_2d(np.asarray(q1, dtype=float))
        if step <= 0 or not np.isfinite(step):
            raise ValueError(f"segment resolution must be a positive number, got {step}")
        span = np.abs(q1 - q0).max(axis=1)
        n = np.maximum(1, np.ceil(span / step).astype(int))
        first = 0 if ends else 1
        counts = n + 1 - first - (0 if ends else 1)
        counts = np.maximum(counts, 0)
        total = int(counts.sum())
        if total == 0:
            return np.ones(len(q0), dtype=bool)
        seg = np.repeat(np.arange(len(q0)), counts)
        offsets = np.cumsum(counts) - counts
        k = np.arange(total) - np.repeat(offsets, counts) + first
        t = (k / n[seg])[:, None]
        samples = q0[seg] + t * (q1[seg] - q0[seg])
        bad = ~np.asarray(self.valid(samples))
        return np.bincount(seg[bad], minlength=len(q0)) == 0

    def segment_free(self, q0: np.ndarray, q1: np.ndarray, step_deg: float = 2.0) -> bool:
        """True when the straight joint-space segment ``q0 -> q1`` (ends included) is valid."""
        return bool(self.segments_free(q0, q1, step_deg, ends=True)[0])

    def check_start(self, q: np.ndarray, what: str = "start") -> None:
        """Raise ConfigError naming the contacts if configuration ``q`` collides."""
        hits = self.contacts(q)
        if hits:
            raise ConfigError(
                f"the arm's {what} configuration {np.round(q, 2).tolist()} overlaps an obstacle: "
                + "; ".join(map(str, hits)),
                file=self.scene.source,
            )

    def fingerprint(self) -> str:
        """Hash of what the answers depend on: model geometry, limits, scene, margin."""
        h = hashlib.sha256()
        h.update(model_fingerprint(self.model).encode())
        h.update(self.scene.fingerprint().encode())
        h.update(repr((self.margin, self.pairs.tolist())).encode())
        return h.hexdigest()

    # -- internals -----------------------------------------------------------------

    def _poses(self, q: np.ndarray) -> np.ndarray:
        """Link box poses ``(N, B, 4, 4)``; a shortcut for the common pure-offset boxes."""
        if not self._translated:
            return self.model.box_poses(q)
        out = self.model.link_frames(q)[:, self._links]
        o = self._offsets
        rot = out[..., :3, :3]
        # Written out: numpy reduces over a length-3 axis far slower than it adds three arrays.
        out[..., :3, 3] += (
            rot[..., 0] * o[:, None, 0] + rot[..., 1] * o[:, None, 1] + rot[..., 2] * o[:, None, 2]
        )
        return out

    def _collides(self, q: np.ndarray) -> np.ndarray:
        poses = self._poses(q)
        mov = poses[:, self.moving]
        hit = self._env(mov, self.half_moving[None])
        if len(self.pairs):
            hit |= self._self_hits(poses).any(axis=1)
        return hit

    def _env(self, poses: np.ndarray, half: np.ndarray) -> np.ndarray:
        """Boolean ``(N,)``: any of the boxes ``poses`` ``(N, B, 4, 4)`` hits the environment."""
        rot, c = poses[..., :3, :3], poses[..., :3, 3]
        hit = np.zeros(len(poses), dtype=bool)
        if self.scene.table_z is not None:
            low = c[..., 2] - np.einsum(
                "nbk,nbk->nb", np.abs(rot[..., 2, :]), np.broadcast_to(half, c.shape)
            )
            hit |= np.any(low < self.scene.table_z - TOUCH_TOL, axis=1)
        oc, orot, oh = self._boxes
        if len(oc):
            hit |= self._box_hits(rot, c, np.broadcast_to(half, c.shape)).any(axis=1)
        if self._mesh is not None:
            hit |= self._mesh_hits(self._mesh, rot, c, half).any(axis=1)
        return hit

    def _box_hits(self, rot: np.ndarray, c: np.ndarray, half: np.ndarray) -> np.ndarray:
        """Boolean ``(N, B)``: box ``b`` of configuration ``n`` overlaps an obstacle box.

        Broad phase per obstacle: the link box's bounding box in the obstacle's
        frame against the obstacle (those are the obstacle's three face axes of
        the separating-axis test, computed for all pairs at once); only pairs it
        cannot separate go through the full 15-axis test.
        """
        oc, orot, oh = self._boxes
        out = np.zeros(c.shape[:2], dtype=bool)
        world_ext = None
        for o in range(len(oc)):
            if self._aligned[o]:
                if world_ext is None:
                    world_ext = _extent(rot, half)
                local, ext = c - oc[o], world_ext
            else:
                local = (c - oc[o]) @ orot[o]
                ext = _extent(np.einsum("ji,...jk->...ik", orot[o], rot), half)
            gap = np.abs(local) - ext
            lim = oh[o] - TOUCH_TOL
            near = (gap[..., 0] < lim[0]) & (gap[..., 1] < lim[1]) & (gap[..., 2] < lim[2])
            n, b = np.nonzero(near)
            if len(n):
                m = len(n)
                out[n, b] |= _sat(
                    np.broadcast_to(orot[o], (m, 3, 3)),
                    rot[n, b],
                    np.broadcast_to(oh[o], (m, 3)),
                    half[n, b],
                    c[n, b] - oc[o],
                    TOUCH_TOL,
                )
        return out

    def _mesh_hits(
        self, mesh: tuple[np.ndarray, ...], rot: np.ndarray, c: np.ndarray, half: np.ndarray
    ) -> np.ndarray:
        """Boolean ``(N, B)``: box ``b`` of configuration ``n`` touches a triangle of ``mesh``
        (:func:`_mesh_arrays`; the callers have ruled out a scene without meshes)."""
        tris, tri_lo, tri_hi, mesh_lo, mesh_hi = mesh
        half = np.broadcast_to(half, c.shape)
        ext = np.einsum("...ij,...j->...i", np.abs(rot), half)
        lo, hi = c - ext, c + ext
        out = np.zeros(c.shape[:2], dtype=bool)
        near = np.all((lo <= mesh_hi) & (hi >= mesh_lo), axis=-1)
        cn, cb = np.nonzero(near)
        if len(cn) == 0:
            return out
        blo, bhi = lo[cn, cb], hi[cn, cb]
        cand = np.all((blo[:, None] <= tri_hi) & (bhi[:, None] >= tri_lo), axis=-1)
        k, t = np.nonzero(cand)
        if len(k) == 0:
            return out
        r, cc, hh = rot[cn[k], cb[k]], c[cn[k], cb[k]], half[cn[k], cb[k]]
        # A mesh triangle wholly inside the box has a vertex inside it.
        local = np.einsum("kvj,kji->kvi", tris[t] - cc[:, None], r)
        inside = np.any(np.all(np.abs(local) < hh[:, None] - TOUCH_TOL, axis=-1), axis=1)
        corners = cc[:, None] + np.einsum("kij,kvj->kvi", r, BOX_CORNER_SIGNS * hh[:, None])
        box_tris = corners[:, BOX_TRIANGLES]  # (K, 12, 3, 3)
        crossing = (
            intersect_pairs(box_tris.reshape(-1, 3, 3), np.repeat(tris[t], 12, axis=0))
            .reshape(-1, 12)
            .any(axis=1)
        )
        touch = inside | crossing
        np.logical_or.at(out, (cn[k], cb[k]), touch)
        return out

    def _self_hits(self, poses: np.ndarray) -> np.ndarray:
        i, j = self.pairs[:, 0], self.pairs[:, 1]
        pi, pj = poses[:, i], poses[:, j]
        return obb_overlap(
            pi[..., :3, 3],
            pi[..., :3, :3],
            self.half[i],
            pj[..., :3, 3],
            pj[..., :3, :3],
            self.half[j],
        )

    def _hits(self, poses: np.ndarray, half: np.ndarray, fixed: bool = False) -> list[str]:
        """What one box (``poses`` ``(1, 1, 4, 4)``) touches in the scene, by name."""
        rot, c = poses[..., :3, :3], poses[..., :3, 3]
        names = []
        if self.scene.table_z is not None and not fixed:
            low = c[0, 0, 2] - np.abs(rot[0, 0, 2, :]) @ half[0, 0]
            if low < self.scene.table_z - TOUCH_TOL:
                names.append("the table")
        oc, orot, oh = self._boxes
        if len(oc):
            ov = obb_overlap(c[0, 0], rot[0, 0], half[0, 0], oc, orot, oh)
            names += [f"obstacle {self.scene.boxes[o].name!r}" for o in np.flatnonzero(ov)]
        if self._mesh is not None and self._mesh_hits(self._mesh, rot, c, half)[0, 0]:
            names.append("a mesh obstacle")
        return names


def _extent(rot: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Half extents ``(..., 3)`` of boxes' axis-aligned bounds: ``|R| @ half``, written out."""
    a = np.abs(rot)
    return (
        a[..., 0] * half[..., None, 0]
        + a[..., 1] * half[..., None, 1]
        + a[..., 2] * half[..., None, 2]
    )


def model_fingerprint(model: KinematicModel) -> str:
    """Hash of a model's geometry and limits (joints, constraints, boxes, frames at probes)."""
    h = hashlib.sha256()
    h.update(f"{type(model).__module__}.{type(model).__qualname__}:{model.name}".encode())
    h.update(repr([(j.name, j.kind, j.lower, j.upper) for j in model.joints]).encode())
    h.update(repr([c.expr for c in model.constraints]).encode())
    h.update(repr([(b.name, b.link, tuple(b.size)) for b in model.boxes]).encode())
    probes = _probe_configs(model)
    h.update(np.round(model.box_poses(probes), 6).tobytes())
    h.update(np.round(np.asarray(model.within_limits(probes), dtype=float), 0).tobytes())
    return h.hexdigest()


def _probe_configs(model: KinematicModel) -> np.ndarray:
    lo, hi = model.lower, model.upper
    rng = np.random.default_rng(12345)
    samples = lo + rng.random((6, model.dof)) * (hi - lo)
    return np.vstack([lo, hi, 0.5 * (lo + hi), samples])


def _obstacle_arrays(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if not scene.boxes:
        return np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros((0, 3))
    return (
        np.array([b.center for b in scene.boxes], dtype=float),
        np.array([b.rotation for b in scene.boxes], dtype=float),
        np.array([0.5 * b.size for b in scene.boxes], dtype=float),
    )


def _mesh_arrays(scene: Scene) -> tuple[np.ndarray, ...] | None:
    if not scene.meshes:
        return None
    tris = np.concatenate([m.triangles for m in scene.meshes])
    lo, hi = tris.min(axis=1), tris.max(axis=1)
    return tris, lo, hi, lo.min(axis=0), hi.max(axis=0)
