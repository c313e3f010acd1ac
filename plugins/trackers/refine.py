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
_MIN_CONTRAST = 8.0


def refine_corners(gray: np.ndarray, quads: np.ndarray, cells: int, passes: int = 2) -> np.ndarray:
    """Refined corners ``(N, 4, 2)`` of quads ``(N, 4, 2)`` running clockwise on screen.

    ``cells`` is the number of cells across a marker (border included), which
    bounds how far a profile may reach. Corners whose edges cannot be measured
    (no contrast, off the image) are left as they were.
    """
    quads = np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2)
    if len(quads) == 0:
        return quads.astype(np.float32)
    out = quads.copy()
    for _ in range(passes):
        out = _refine_once(gray, out, cells)
    return out.astype(np.float32)


_NEXT = np.array([1, 2, 3, 0])
_PREV = np.array([3, 0, 1, 2])


def _refine_once(gray: np.ndarray, quads: np.ndarray, cells: int) -> np.ndarray:
    n = len(quads)
    d = quads[:, _NEXT] - quads  # edge k runs from corner k to corner k+1, (N, 4, 2)
    length = np.maximum(np.sqrt((d * d).sum(axis=2)), 1e-9)  # (N, 4)
    unit = d / length[..., None]
    normal_out = np.stack([unit[..., 1], -unit[..., 0]], axis=-1)  # outwards for clockwise quads
    side = length.mean(axis=1)  # (N,)
    reach = np.clip(0.8 * side / cells, 0.8, 4.0)  # (N,) pixels
    # points along each edge (N, 4, T, 2), then profiles across it (N, 4, T, S, 2)
    base = quads[:, :, None, :] + _T[None, None, :, None] * d[:, :, None, :]
    step = reach[:, None, None] * normal_out  # (N, 4, 2)
    pts = base[:, :, :, None, :] + _S[None, None, None, :, None] * step[:, :, None, None, :]
    flat = pts.astype(np.float32).reshape(-1, 1, 2)
    values = cv2.remap(
        gray, flat[..., 0], flat[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
    )
    v = values.reshape(n, 4, len(_T), len(_S)).astype(np.float64)
    inside = 0.5 * (v[..., 0] + v[..., 1])
    contrast = 0.5 * (v[..., -1] + v[..., -2]) - inside
    valid = contrast > _MIN_CONTRAST
    frac = np.clip((v - inside[..., None]) / np.where(valid, contrast, 1.0)[..., None], 0.0, 1.0)
    # e = w - integral of the light fraction over [-w, w] (trapezoid), in units of reach
    integral = _DS * (frac.sum(axis=-1) - 0.5 * (frac[..., 0] + frac[..., -1]))
    e = (1.0 - integral) * reach[:, None, None]  # (N, 4, T) px along normal_out
    edge_pts = base + e[..., None] * normal_out[:, :, None, :]
    # weighted total-least-squares line through each edge's points (closed form in 2-D)
    w = valid.astype(np.float64)
    count = w.sum(axis=2)  # (N, 4)
    ok_edge = count >= 4
    wsum = np.maximum(count, 1.0)
    centre = (w[..., None] * edge_pts).sum(axis=2) / wsum[..., None]  # (N, 4, 2)
    r = edge_pts - centre[:, :, None, :]
    sxx = (w * r[..., 0] * r[..., 0]).sum(axis=2)
    syy = (w * r[..., 1] * r[..., 1]).sum(axis=2)
    sxy = (w * r[..., 0] * r[..., 1]).sum(axis=2)
    angle = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    direction = np.stack([np.cos(angle), np.sin(angle)], axis=-1)
    direction = np.where(ok_edge[..., None], direction, unit)
    centre = np.where(ok_edge[..., None], centre, quads + 0.5 * d)
    # corner k is where edge k-1 (ending at k) meets edge k (starting at k)
    p1, d1 = centre[:, _PREV], direction[:, _PREV]
    denom = d1[..., 0] * direction[..., 1] - d1[..., 1] * direction[..., 0]
    diff = centre - p1
    parallel = np.abs(denom) < 1e-6
    t = (diff[..., 0] * direction[..., 1] - diff[..., 1] * direction[..., 0]) / np.where(
        parallel, 1.0, denom
    )
    corners = p1 + t[..., None] * d1
    moved = np.sqrt(((corners - quads) ** 2).sum(axis=2))
    # a corner that jumps more than two cells is a failed fit, not a refinement
    keep = ok_edge & ok_edge[:, _PREV] & ~parallel & (moved < (2.0 * side / cells)[:, None])
    return np.where(keep[..., None], corners, quads)
