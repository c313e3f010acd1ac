"""Sub-pixel marker corners from the four edges of the black square.

OpenCV's ``cornerSubPix`` looks at the corner itself, where a blurred L
shape pulls the estimate towards the dark side by 0.1 to 0.3 px. Here each
edge is located instead, at many points away from the corners, each from a
short intensity profile across it: with the dark and light levels taken at
the profile's ends, the edge lies where the area under the normalised
profile says a step would be (``e = w - integral of the light fraction``),
which is exact for any symmetric blur and averages noise out. A line is
fitted through each edge's points and the corners are the intersections of
neighbouring lines. All markers, edges and profiles go through one
``cv2.remap`` per pass.

The profiles reach ``0.8`` of a cell inwards (so they stay on the black
border, whatever the bits inside) and as far outwards (into the quiet zone).
"""

from __future__ import annotations

import cv2
import numpy as np

#: Points along each edge (avoiding the corners' rounded ends) and samples per profile.
_T = np.linspace(0.15, 0.85, 10)
_S = np.linspace(-1.0, 1.0, 13)
_DS = _S[1] - _S[0]
#: Trapezoid-rule weights over a profile's samples.
_TRAPEZOID = np.full(len(_S), _DS)
_TRAPEZOID[[0, -1]] *= 0.5
_HALVES = np.array([0.5, 0.5])
_MIN_CONTRAST = 8.0


def refine_corners(
    image: np.ndarray, quads: np.ndarray, cells: int, passes: int = 2, contour_inset: float = 0.0
) -> np.ndarray:
    """Refined corners ``(N, 4, 2)`` of quads ``(N, 4, 2)`` running clockwise on screen.

    ``image`` is the grey frame, or the BGR one (sampled as grey, see :func:`remap_points`).

    ``cells`` is the number of cells across a marker (border included), which
    bounds how far a profile may reach. A further pass (up to ``passes``) is
    made only for markers whose corners moved so far that the first profiles
    ended within the blur of the edge.
    Corners whose edges cannot be measured (no contrast, off the image) are
    left as they were. ``contour_inset`` (px) says how far inside both edges the
    given corners sit: corners taken from a dark region's contour run through
    its outermost pixel centres, half a pixel inside the edge; they are pushed
    out first, which usually saves the second pass.
    """
    quads = np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2)
    if len(quads) == 0:
        return quads.astype(np.float32)
    # points as complex numbers x + iy: half the numpy calls of separate x and y
    out = np.ascontiguousarray(quads).view(np.complex128)[..., 0].copy()  # (N, 4), not the caller's
    if contour_inset:
        away = out - 0.25 * out.sum(axis=1, keepdims=True)
        out = out + (contour_inset * np.sqrt(2.0)) * away / np.maximum(np.abs(away), 1e-6)
    active = np.ones(len(out), dtype=bool)
    for _ in range(passes):
        before = out[active]
        after, reach = _refine_once(image, before, cells)
        out[active] = after
        moved = np.abs(after - before).max(axis=1)
        # a profile that ended within the blur of the edge biases the fit
        still = moved > 0.3 * reach
        if not still.any():
            break
        active[np.flatnonzero(active)[~still]] = False
    return out.view(np.float64).reshape(-1, 4, 2).astype(np.float32)


#: Points per row handed to ``cv2.remap`` (it refuses rows of 32767 or more).
_ROW_POINTS = 16384


#: OpenCV's BGR-to-grey weights (``cv2.COLOR_BGR2GRAY``), for sampling colour frames.
_BGR_TO_GRAY = np.array([0.114, 0.587, 0.299])


def remap_points(image: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Bilinear grey levels ``(P,)`` float64 of ``image`` at pixel points ``(P, 2)`` (x, y).

    ``image`` is grey or BGR ``uint8``; a BGR image is sampled per channel and
    weighted as ``cv2.cvtColor`` weighs it, so a tracker that needs grey levels
    at a few thousand points need not convert the whole frame (to within
    cvtColor's rounding, half a grey level). Edge pixels repeat beyond the image
    (``BORDER_REPLICATE``). The points go to ``cv2.remap`` as one row when they
    fit in one: OpenCV splits a remap by rows between its threads, and for the
    few thousand points a frame needs, waking them (and their spinning
    afterwards) costs more CPU time than the work.
    """
    points = np.asarray(points, dtype=np.float32).reshape(-1, 2)
    count = len(points)
    if count == 0:
        return np.zeros(0)
    rows = -(-count // _ROW_POINTS)
    if rows > 1:
        points = np.concatenate([points, np.zeros((rows * _ROW_POINTS - count, 2), np.float32)])
    maps = points.reshape(rows, -1, 2)
    values = cv2.remap(image, maps, None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    if values.ndim == 3:
        return (values.reshape(-1, 3)[:count] @ _BGR_TO_GRAY).astype(np.float64)
    return values.reshape(-1)[:count].astype(np.float64)


_NEXT = np.array([1, 2, 3, 0])
_PREV = np.array([3, 0, 1, 2])


def _refine_once(image: np.ndarray, quads: np.ndarray, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """One pass over quads given as complex corners ``x + iy (N, 4)``: refined corners, reach (px).

    This runs on a handful of markers per frame, where the count of numpy
    calls, not their size, sets the time: hence complex points, not x and y.
    """
    n = len(quads)
    d = quads[:, _NEXT] - quads  # edge k runs from corner k to corner k+1
    length = np.maximum(np.abs(d), 1e-9)
    u = d / length
    normal = -1j * u  # outward normal of a clockwise quad (y down)
    side = 0.25 * length.sum(axis=1)  # (N,)
    reach = np.minimum(np.maximum(0.8 * side / cells, 0.8), 4.0)  # (N,) pixels
    # points along each edge (N, 4, T), then profiles across it (N, 4, T, S)
    base = quads[..., None] + _T * d[..., None]
    points = base[..., None] + (reach[:, None] * normal)[..., None, None] * _S
    values = remap_points(image, points.view(np.float64).reshape(-1, 2))
    v = values.reshape(n, 4, len(_T), len(_S))
    inside = v[..., :2] @ _HALVES
    contrast = v[..., -2:] @ _HALVES - inside
    valid = contrast > _MIN_CONTRAST
    frac = np.clip((v - inside[..., None]) / np.where(valid, contrast, 1.0)[..., None], 0.0, 1.0)
    # e = w - integral of the light fraction over [-w, w] (trapezoid), in units of reach
    e = (1.0 - frac @ _TRAPEZOID) * reach[:, None, None]  # (N, 4, T) px along the normal
    edge = base + e * normal[..., None]
    # weighted total-least-squares line through each edge's points: with r = z - centroid,
    # the line's direction is the square root of sum(w r^2) (closed form in 2-D)
    w = valid.astype(np.float64)
    count = w.sum(axis=2)  # (N, 4)
    ok_edge = count >= 4
    centre = (w * edge).sum(axis=2) / np.maximum(count, 1.0)
    r = edge - centre[..., None]
    direction = np.exp(0.5j * np.angle((w * r * r).sum(axis=2)))
    direction = np.where(ok_edge, direction, u)
    centre = np.where(ok_edge, centre, quads + 0.5 * d)
    # corner k is where edge k-1 (ending at k) meets edge k (starting at k)
    p, pw = centre[:, _PREV], direction[:, _PREV]
    denom = (pw.conj() * direction).imag
    parallel = np.abs(denom) < 1e-6
    t = ((centre - p).conj() * direction).imag / np.where(parallel, 1.0, denom)
    corners = p + t * pw
    # a corner that jumps more than two cells is a failed fit, not a refinement
    keep = (
        ok_edge
        & ok_edge[:, _PREV]
        & ~parallel
        & (np.abs(corners - quads) < (2.0 * side / cells)[:, None])
    )
    return np.where(keep, corners, quads), reach
