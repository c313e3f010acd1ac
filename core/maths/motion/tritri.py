"""Exact triangle-triangle intersection after Moller (1997), one pair or millions at once.

Showers 2016 (Collision Detection, Algorithm 1) checks the Dobot's mesh against the
scene with "A Fast Triangle-Triangle Intersection Test" (T. Moller, Journal of
Graphics Tools 2(2), 1997): reject when one triangle lies on one side of the
other's plane, else compare the two triangles' intervals on the line where the
planes meet; coplanar triangles are tested in 2-D (edge crossings and
vertex-in-triangle, Showers 2016 eq. 14).

Triangles are ``(..., 3, 3)`` arrays: three vertices of x, y, z in mm. Touching
counts as intersecting. Signed plane distances below ``1e-9`` mm (measured with
the L1 norm of the plane normal, so slightly generous) are snapped to zero,
exactly as Moller's EPSILON test, in both the scalar and the batched versions so
they agree bit for bit on the decision.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Plane-distance tolerance in mm (Moller's EPSILON, made scale-aware through |n|_1).
PLANE_TOL = 1e-9

# Pairs of edges for the coplanar test: (edge of T1, edge of T2) as vertex indices.
_EDGES = ((0, 1), (1, 2), (2, 0))


# ---------------------------------------------------------------------------
# One pair, plain Python: the readable reference and the benchmark's baseline.
# ---------------------------------------------------------------------------


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _plane_distances(tri, other):
    n = _cross(_sub(other[1], other[0]), _sub(other[2], other[0]))
    d = -_dot(n, other[0])
    tol = PLANE_TOL * (abs(n[0]) + abs(n[1]) + abs(n[2]))
    out = []
    for v in tri:
        dist = _dot(n, v) + d
        out.append(0.0 if abs(dist) <= tol else dist)
    return n, out


def _lonely(d):
    d0, d1, d2 = d
    if d0 * d1 > 0:
        return 2
    if d0 * d2 > 0:
        return 1
    if d1 * d2 > 0 or d0 != 0:
        return 0
    if d1 != 0:
        return 1
    return 2


def _interval(p, d):
    k = _lonely(d)
    i, j = (k + 1) % 3, (k + 2) % 3
    a = p[k] + (p[i] - p[k]) * d[k] / (d[k] - d[i])
    b = p[k] + (p[j] - p[k]) * d[k] / (d[k] - d[j])
    return (a, b) if a <= b else (b, a)


def _orient(a, b, c):
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def _segments_cross_2d(p1, p2, q1, q2):
    o1, o2 = _orient(p1, p2, q1), _orient(p1, p2, q2)
    o3, o4 = _orient(q1, q2, p1), _orient(q1, q2, p2)
    if o1 == 0 and o2 == 0 and o3 == 0 and o4 == 0:
        return all(
            min(p1[k], p2[k]) <= max(q1[k], q2[k]) and min(q1[k], q2[k]) <= max(p1[k], p2[k])
            for k in (0, 1)
        )
    return o1 * o2 <= 0 and o3 * o4 <= 0


def _point_in_triangle_2d(p, t):
    s0, s1, s2 = _orient(t[0], t[1], p), _orient(t[1], t[2], p), _orient(t[2], t[0], p)
    return (s0 >= 0 and s1 >= 0 and s2 >= 0) or (s0 <= 0 and s1 <= 0 and s2 <= 0)


def _coplanar(n, t1, t2):
    drop = max(range(3), key=lambda k: abs(n[k]))
    keep = [k for k in range(3) if k != drop]
    a = [(v[keep[0]], v[keep[1]]) for v in t1]
    b = [(v[keep[0]], v[keep[1]]) for v in t2]
    for i0, i1 in _EDGES:
        for j0, j1 in _EDGES:
            if _segments_cross_2d(a[i0], a[i1], b[j0], b[j1]):
                return True
    return _point_in_triangle_2d(a[0], b) or _point_in_triangle_2d(b[0], a)


def triangles_intersect(t1: Sequence[Sequence[float]], t2: Sequence[Sequence[float]]) -> bool:
    """True when triangles ``t1`` and ``t2`` (three xyz vertices each, mm) touch or cross.

    Plain Python, one pair at a time: Moller's algorithm step by step (Showers 2016,
    Algorithm 1). Use :func:`intersect_pairs` or :func:`intersect_matrix` for batches.
    """
    t1 = [tuple(map(float, v)) for v in t1]
    t2 = [tuple(map(float, v)) for v in t2]
    _, dv = _plane_distances(t1, t2)
    if all(x > 0 for x in dv) or all(x < 0 for x in dv):
        return False
    n1, du = _plane_distances(t2, t1)
    if all(x > 0 for x in du) or all(x < 0 for x in du):
        return False
    if all(x == 0 for x in dv) or all(x == 0 for x in du):
        return _coplanar(n1, t1, t2)
    n2 = _cross(_sub(t2[1], t2[0]), _sub(t2[2], t2[0]))
    line = _cross(n1, n2)
    axis = max(range(3), key=lambda k: abs(line[k]))
    lo1, hi1 = _interval([v[axis] for v in t1], dv)
    lo2, hi2 = _interval([v[axis] for v in t2], du)
    return not (hi1 < lo2 or hi2 < lo1)


# ---------------------------------------------------------------------------
# Batched: numpy over N pairs, and over every pair of two sets.
# ---------------------------------------------------------------------------


def _vdot(n: np.ndarray, v: np.ndarray) -> np.ndarray:
    # Written out (no BLAS, no FMA) so every pair rounds exactly as the scalar reference.
    return n[..., 0] * v[..., 0] + n[..., 1] * v[..., 1] + n[..., 2] * v[..., 2]


def _normals(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    n = np.stack(
        [
            e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1],
            e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2],
            e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0],
        ],
        axis=1,
    )
    return n, -_vdot(n, t[:, 0])


def _orient2(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (
        c[..., 0] - a[..., 0]
    )


def _coplanar_batch(n1: np.ndarray, t1: np.ndarray, t2: np.ndarray) -> np.ndarray:
    drop = np.argmax(np.abs(n1), axis=1)
    keep = np.array([[1, 2], [0, 2], [0, 1]])[drop]
    a = np.take_along_axis(t1, keep[:, None, :], axis=2)
    b = np.take_along_axis(t2, keep[:, None, :], axis=2)
    hit = np.zeros(len(n1), dtype=bool)
    for i0, i1 in _EDGES:
        p1, p2 = a[:, i0], a[:, i1]
        for j0, j1 in _EDGES:
            q1, q2 = b[:, j0], b[:, j1]
            o1, o2 = _orient2(p1, p2, q1), _orient2(p1, p2, q2)
            o3, o4 = _orient2(q1, q2, p1), _orient2(q1, q2, p2)
            collinear = (o1 == 0) & (o2 == 0) & (o3 == 0) & (o4 == 0)
            boxes = np.all(
                (np.minimum(p1, p2) <= np.maximum(q1, q2))
                & (np.minimum(q1, q2) <= np.maximum(p1, p2)),
                axis=1,
            )
            hit |= np.where(collinear, boxes, (o1 * o2 <= 0) & (o3 * o4 <= 0))

    def inside(p: np.ndarray, t: np.ndarray) -> np.ndarray:
        s0, s1, s2 = (
            _orient2(t[:, 0], t[:, 1], p),
            _orient2(t[:, 1], t[:, 2], p),
            _orient2(t[:, 2], t[:, 0], p),
        )
        return ((s0 >= 0) & (s1 >= 0) & (s2 >= 0)) | ((s0 <= 0) & (s1 <= 0) & (s2 <= 0))

    return hit | inside(a[:, 0], b) | inside(b[:, 0], a)


def _soa(t: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` triangles as ``(vertex, coordinate, N)``: every coordinate contiguous."""
    return np.ascontiguousarray(t.transpose(1, 2, 0))


def _plane_soa(tri: np.ndarray) -> tuple[tuple[np.ndarray, ...], np.ndarray, np.ndarray]:
    """Normals, offsets and snapping tolerances of triangles in SoA form (the reference's order)."""
    e1 = tri[1] - tri[0]
    e2 = tri[2] - tri[0]
    nx = e1[1] * e2[2] - e1[2] * e2[1]
    ny = e1[2] * e2[0] - e1[0] * e2[2]
    nz = e1[0] * e2[1] - e1[1] * e2[0]
    d = -(nx * tri[0][0] + ny * tri[0][1] + nz * tri[0][2])
    return (nx, ny, nz), d, PLANE_TOL * (np.abs(nx) + np.abs(ny) + np.abs(nz))


def _distances_soa(
    tri: np.ndarray, n: tuple[np.ndarray, ...], d: np.ndarray, tol: np.ndarray
) -> list[np.ndarray]:
    out = []
    for v in tri:
        dist = n[0] * v[0] + n[1] * v[1] + n[2] * v[2] + d
        out.append(np.where(np.abs(dist) <= tol, 0.0, dist))
    return out


def _one_side_soa(d: list[np.ndarray]) -> np.ndarray:
    return ((d[0] > 0) & (d[1] > 0) & (d[2] > 0)) | ((d[0] < 0) & (d[1] < 0) & (d[2] < 0))


def _interval_soa(p: list[np.ndarray], d: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Where a triangle crosses the line of the two planes, as in :func:`_interval`."""
    d0, d1, d2 = d
    c01 = d0 * d1 > 0
    c02 = ~c01 & (d0 * d2 > 0)
    k0 = ~c01 & ~c02 & ((d1 * d2 > 0) | (d0 != 0))
    k1 = c02 | (~c01 & ~c02 & ~k0 & (d1 != 0))

    def pick(x0: np.ndarray, x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
        return np.where(k0, x0, np.where(k1, x1, x2))

    pk, pi, pj = pick(p[0], p[1], p[2]), pick(p[1], p[2], p[0]), pick(p[2], p[0], p[1])
    dk, di, dj = pick(d0, d1, d2), pick(d1, d2, d0), pick(d2, d0, d1)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = pk + (pi - pk) * dk / (dk - di)
        y = pk + (pj - pk) * dk / (dk - dj)
    return np.minimum(x, y), np.maximum(x, y)


def intersect_pairs(t1: np.ndarray, t2: np.ndarray) -> np.ndarray:
    """Boolean ``(N,)``: does triangle ``t1[k]`` touch or cross ``t2[k]``? (``(N, 3, 3)`` mm).

    The same decisions as :func:`triangles_intersect`, vectorised: the plane
    rejections run on all pairs, the interval step only on the pairs that survive.
    """
    t1 = np.asarray(t1, dtype=float).reshape(-1, 3, 3)
    t2 = np.asarray(t2, dtype=float).reshape(-1, 3, 3)
    if len(t1) > _BLOCK:
        # Blocks whose temporaries stay in cache run several times faster than one
        # pass over millions of pairs.
        return np.concatenate(
            [_pairs(t1[s : s + _BLOCK], t2[s : s + _BLOCK]) for s in range(0, len(t1), _BLOCK)]
        )
    return _pairs(t1, t2)


#: Pairs per block in :func:`intersect_pairs`.
_BLOCK = 4096


def _pairs(t1: np.ndarray, t2: np.ndarray) -> np.ndarray:
    """One block of :func:`intersect_pairs`, in structure-of-arrays form throughout."""
    out = np.zeros(len(t1), dtype=bool)
    a, b = _soa(t1), _soa(t2)
    n2, off2, tol2 = _plane_soa(b)
    dv = _distances_soa(a, n2, off2, tol2)
    live = np.flatnonzero(~_one_side_soa(dv))
    if len(live) == 0:
        return out
    a, b = a[:, :, live], b[:, :, live]
    n2 = tuple(x[live] for x in n2)
    dv = [x[live] for x in dv]
    n1, off1, tol1 = _plane_soa(a)
    du = _distances_soa(b, n1, off1, tol1)
    keep = np.flatnonzero(~_one_side_soa(du))
    if len(keep) == 0:
        return out
    live, a, b = live[keep], a[:, :, keep], b[:, :, keep]
    n1, n2 = tuple(x[keep] for x in n1), tuple(x[keep] for x in n2)
    dv, du = [x[keep] for x in dv], [x[keep] for x in du]
    # Project onto the axis most aligned with the planes' line of intersection.
    lx = np.abs(n1[1] * n2[2] - n1[2] * n2[1])
    ly = np.abs(n1[2] * n2[0] - n1[0] * n2[2])
    lz = np.abs(n1[0] * n2[1] - n1[1] * n2[0])
    use_x = (lx >= ly) & (lx >= lz)
    use_y = ~use_x & (ly >= lz)

    def project(tri: np.ndarray) -> list[np.ndarray]:
        return [np.where(use_x, v[0], np.where(use_y, v[1], v[2])) for v in tri]

    lo1, hi1 = _interval_soa(project(a), dv)
    lo2, hi2 = _interval_soa(project(b), du)
    hit = ~((hi1 < lo2) | (hi2 < lo1))
    coplanar = ((dv[0] == 0) & (dv[1] == 0) & (dv[2] == 0)) | (
        (du[0] == 0) & (du[1] == 0) & (du[2] == 0)
    )
    if coplanar.any():
        rows = live[coplanar]
        normal = np.stack([x[coplanar] for x in n1], axis=1)
        hit[coplanar] = _coplanar_batch(normal, t1[rows], t2[rows])
    out[live] = hit
    return out


def _one_side_of(d0: np.ndarray, d1: np.ndarray, d2: np.ndarray, tol: np.ndarray) -> np.ndarray:
    """All three vertex distances beyond ``tol`` on the same side of the plane."""
    return (np.minimum(np.minimum(d0, d1), d2) > tol) | (np.maximum(np.maximum(d0, d1), d2) < -tol)


def intersect_matrix(a: np.ndarray, b: np.ndarray, chunk: int = 1 << 17) -> np.ndarray:
    """Boolean ``(Na, Nb)``: every triangle of ``a`` against every triangle of ``b`` (mm).

    The plane rejections of all ``Na * Nb`` pairs are matrix products (each
    triangle's plane is computed once, not once per pair); only the pairs that
    straddle both planes go on to :func:`intersect_pairs`. ``chunk`` bounds the
    number of vertex-plane distances held in memory at once.
    """
    a = np.asarray(a, dtype=float).reshape(-1, 3, 3)
    b = np.asarray(b, dtype=float).reshape(-1, 3, 3)
    out = np.zeros((len(a), len(b)), dtype=bool)
    if len(a) == 0 or len(b) == 0:
        return out
    na, da = _normals(a)
    nb, db = _normals(b)
    # The matrix products round differently from the pairwise test, so this prefilter
    # rejects only with a margin of a few ulps; :func:`intersect_pairs` decides the rest.
    scale = 16 * np.finfo(float).eps * max(np.abs(a).max(), np.abs(b).max(), 1.0)
    tol_a = (PLANE_TOL + scale) * np.abs(na).sum(axis=1)
    tol_b = (PLANE_TOL + scale) * np.abs(nb).sum(axis=1)
    # Distances of b's vertices to a's planes do not depend on the a-chunk: hold them once.
    vb = b.reshape(-1, 3)
    step = max(1, chunk // (3 * len(b)))
    for s in range(0, len(a), step):
        e = min(len(a), s + step)
        dist_a = (a[s:e].reshape(-1, 3) @ nb.T).reshape(e - s, 3, len(b)) + db
        side_a = _one_side_of(dist_a[:, 0], dist_a[:, 1], dist_a[:, 2], tol_b)
        dist_b = (vb @ na[s:e].T).reshape(len(b), 3, e - s) + da[s:e]
        side_b = _one_side_of(dist_b[:, 0], dist_b[:, 1], dist_b[:, 2], tol_a[s:e])
        ia, ib = np.nonzero(~(side_a | side_b.T))
        if len(ia):
            out[s + ia, ib] = intersect_pairs(a[s + ia], b[ib])
    return out
