"""The trackers' per-point loops, compiled with numba: grey levels, edge fits, cell samples.

A frame holds a handful of markers, and each step of corner refinement and
cell reading is a small computation on a few thousand points. As numpy
calls, the count of calls, not their size, set the time (about 0.4 ms a
frame, more than finding the markers); compiled loops do the same work in a
few tens of microseconds. Functions are compiled on first use and cached
on disk (``cache=True``): only the first run after an install pays the
compilation (about 4 s for the aruco tracker's loops, 8 s for both
trackers'); later runs load them in 0.4 s, numba's import included. The
modules that call them import this one on first use, so commands that
never look at a marker do not import numba.

Pixel coordinates are OpenCV's: x to the right, y down, pixel centres at
integers. Images are ``uint8``, grey ``(H, W)`` or BGR ``(H, W, 3)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numba
import numpy as np


def compiled(function: Callable[..., Any]) -> Any:
    """``function`` compiled by numba (no GIL), its machine code cached on disk when it can be.

    numba refuses to cache where neither the package's folder nor the user's
    cache folder is writable (a read-only container, say); the function is
    then compiled afresh in each process rather than failing to import.
    """
    try:
        return numba.njit(cache=True, nogil=True)(function)
    except RuntimeError:  # "cannot cache function ...: no locator available"
        return numba.njit(nogil=True)(function)


# cv2.COLOR_BGR2GRAY's weights (a tuple: numba freezes it into the compiled code)
_BGR = (0.114, 0.587, 0.299)


@compiled
def grey_at(image: np.ndarray, x: float, y: float) -> float:
    """Bilinear grey level of ``image`` at ``(x, y)``; edge pixels repeat beyond the image.

    BGR pixels are weighed as ``cv2.cvtColor`` weighs them. A non-finite
    coordinate reads the nearest edge, never memory outside the image.
    """
    h, w = image.shape[0], image.shape[1]
    # written so that NaN fails the test and lands on the edge
    if not x >= 0.0:
        x = 0.0
    elif x > w - 1.0:
        x = w - 1.0
    if not y >= 0.0:
        y = 0.0
    elif y > h - 1.0:
        y = h - 1.0
    x0, y0 = int(x), int(y)
    x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
    fx, fy = x - x0, y - y0
    if image.ndim == 2:
        top = image[y0, x0] * (1.0 - fx) + image[y0, x1] * fx
        bottom = image[y1, x0] * (1.0 - fx) + image[y1, x1] * fx
        return top * (1.0 - fy) + bottom * fy
    level = 0.0
    for channel in range(3):
        top = image[y0, x0, channel] * (1.0 - fx) + image[y0, x1, channel] * fx
        bottom = image[y1, x0, channel] * (1.0 - fx) + image[y1, x1, channel] * fx
        level += _BGR[channel] * (top * (1.0 - fy) + bottom * fy)
    return level


@compiled
def _refine_quad(
    image: np.ndarray,
    quad: np.ndarray,
    cells: float,
    along: np.ndarray,
    across: np.ndarray,
    weights: np.ndarray,
    min_contrast: float,
    out: np.ndarray,
) -> float:
    """One refinement pass of one quad ``(4, 2)`` into ``out``; returns the profiles' reach (px).

    See :mod:`.refine` for the method. Edge k runs from corner k to corner
    k + 1; corner k is where edges k - 1 and k meet.
    """
    n_along, n_across = along.shape[0], across.shape[0]
    side = 0.0
    for k in range(4):
        side += math.hypot(quad[(k + 1) % 4, 0] - quad[k, 0], quad[(k + 1) % 4, 1] - quad[k, 1])
    side *= 0.25
    reach = min(max(0.8 * side / cells, 0.8), 4.0)
    centre = np.empty((4, 2))
    direction = np.empty((4, 2))
    fitted = np.zeros(4, dtype=np.bool_)
    ex = np.empty(n_along)
    ey = np.empty(n_along)
    ok = np.empty(n_along, dtype=np.bool_)
    profile = np.empty(n_across)
    for k in range(4):
        dx = quad[(k + 1) % 4, 0] - quad[k, 0]
        dy = quad[(k + 1) % 4, 1] - quad[k, 1]
        length = max(math.hypot(dx, dy), 1e-9)
        # outward normal of a clockwise quad (y down)
        nx, ny = dy / length * reach, -dx / length * reach
        count = 0
        for t in range(n_along):
            bx, by = quad[k, 0] + along[t] * dx, quad[k, 1] + along[t] * dy
            for s in range(n_across):
                profile[s] = grey_at(image, bx + across[s] * nx, by + across[s] * ny)
            dark = 0.5 * (profile[0] + profile[1])
            contrast = 0.5 * (profile[n_across - 2] + profile[n_across - 1]) - dark
            ok[t] = contrast > min_contrast
            if not ok[t]:
                continue
            count += 1
            # e = w - integral of the light fraction over [-w, w], in units of reach
            light = 0.0
            for s in range(n_across):
                fraction = min(max((profile[s] - dark) / contrast, 0.0), 1.0)
                light += weights[s] * fraction
            e = 1.0 - light
            ex[t], ey[t] = bx + e * nx, by + e * ny
        if count < 4:
            continue
        mx = my = 0.0
        for t in range(n_along):
            if ok[t]:
                mx += ex[t]
                my += ey[t]
        mx /= count
        my /= count
        # total-least-squares line: its direction is half the angle of sum((r_x + i r_y)^2)
        cos2 = sin2 = 0.0
        for t in range(n_along):
            if ok[t]:
                rx, ry = ex[t] - mx, ey[t] - my
                cos2 += rx * rx - ry * ry
                sin2 += 2.0 * rx * ry
        angle = 0.5 * math.atan2(sin2, cos2)
        centre[k, 0], centre[k, 1] = mx, my
        direction[k, 0], direction[k, 1] = math.cos(angle), math.sin(angle)
        fitted[k] = True
    limit = 2.0 * side / cells  # a corner that jumps more than two cells is a failed fit
    for k in range(4):
        out[k, 0], out[k, 1] = quad[k, 0], quad[k, 1]
        p = (k + 3) % 4
        if not (fitted[k] and fitted[p]):
            continue
        denom = direction[p, 0] * direction[k, 1] - direction[p, 1] * direction[k, 0]
        if abs(denom) < 1e-6:
            continue
        t_ = (
            (centre[k, 0] - centre[p, 0]) * direction[k, 1]
            - (centre[k, 1] - centre[p, 1]) * direction[k, 0]
        ) / denom
        x = centre[p, 0] + t_ * direction[p, 0]
        y = centre[p, 1] + t_ * direction[p, 1]
        if math.hypot(x - quad[k, 0], y - quad[k, 1]) < limit:
            out[k, 0], out[k, 1] = x, y
    return reach


@compiled
def refine_quads(
    image: np.ndarray,
    quads: np.ndarray,
    cells: float,
    passes: int,
    inset: float,
    along: np.ndarray,
    across: np.ndarray,
    weights: np.ndarray,
    min_contrast: float,
) -> np.ndarray:
    """Refined corners ``(N, 4, 2)`` of ``quads (N, 4, 2)``; see :func:`.refine.refine_corners`."""
    out = np.empty((quads.shape[0], 4, 2))
    current = np.empty((4, 2))
    refined = np.empty((4, 2))
    for m in range(quads.shape[0]):
        cx = 0.25 * (quads[m, 0, 0] + quads[m, 1, 0] + quads[m, 2, 0] + quads[m, 3, 0])
        cy = 0.25 * (quads[m, 0, 1] + quads[m, 1, 1] + quads[m, 2, 1] + quads[m, 3, 1])
        for k in range(4):
            ax, ay = quads[m, k, 0] - cx, quads[m, k, 1] - cy
            push = inset * math.sqrt(2.0) / max(math.hypot(ax, ay), 1e-6)
            current[k, 0], current[k, 1] = quads[m, k, 0] + push * ax, quads[m, k, 1] + push * ay
        for _ in range(passes):
            reach = _refine_quad(
                image, current, cells, along, across, weights, min_contrast, refined
            )
            moved = 0.0
            for k in range(4):
                moved = max(
                    moved, math.hypot(refined[k, 0] - current[k, 0], refined[k, 1] - current[k, 1])
                )
                current[k, 0], current[k, 1] = refined[k, 0], refined[k, 1]
            # a profile that ended within the blur of the edge biases the fit: once more
            if moved <= 0.3 * reach:
                break
        out[m] = current
    return out


@compiled
def sample_cells(
    image: np.ndarray, quads: np.ndarray, cell_uv: np.ndarray, quiet_uv: np.ndarray
) -> np.ndarray:
    """Grey levels ``(N, C + Q)`` of each quad ``(N, 4, 2)``'s cells, then of its quiet zone.

    ``cell_uv (C, S, 2)`` are S points in each of C cells, ``quiet_uv (Q, 2)``
    single points, all on the unit square, which is mapped onto each quad
    projectively, (0,0), (1,0), (1,1), (0,1) to its corners, in closed form
    (Heckbert 1989, square to quadrilateral). A cell's level is the mean of
    its points. A degenerate quad reads its first corner's level everywhere.
    """
    n_cells, per_cell = cell_uv.shape[0], cell_uv.shape[1]
    out = np.empty((quads.shape[0], n_cells + quiet_uv.shape[0]))
    for m in range(quads.shape[0]):
        x0, y0 = quads[m, 0, 0], quads[m, 0, 1]
        x1, y1 = quads[m, 1, 0], quads[m, 1, 1]
        x2, y2 = quads[m, 2, 0], quads[m, 2, 1]
        x3, y3 = quads[m, 3, 0], quads[m, 3, 1]
        dx1, dx2, dx3 = x1 - x2, x3 - x2, x0 - x1 + x2 - x3
        dy1, dy2, dy3 = y1 - y2, y3 - y2, y0 - y1 + y2 - y3
        den = dx1 * dy2 - dx2 * dy1
        if abs(den) < 1e-12:
            out[m, :] = grey_at(image, x0, y0)
            continue
        g = (dx3 * dy2 - dx2 * dy3) / den
        h = (dx1 * dy3 - dx3 * dy1) / den
        a, b = x1 - x0 + g * x1, x3 - x0 + h * x3
        d, e = y1 - y0 + g * y1, y3 - y0 + h * y3
        for i in range(n_cells + quiet_uv.shape[0]):
            total = 0.0
            count = per_cell if i < n_cells else 1
            for j in range(count):
                if i < n_cells:
                    u, v = cell_uv[i, j, 0], cell_uv[i, j, 1]
                else:
                    u, v = quiet_uv[i - n_cells, 0], quiet_uv[i - n_cells, 1]
                w = g * u + h * v + 1.0
                if abs(w) < 1e-12:
                    w = 1e-12
                total += grey_at(image, (a * u + b * v + x0) / w, (d * u + e * v + y0) / w)
            out[m, i] = total / count
    return out


@compiled
def read_markers(
    reading: np.ndarray,
    border: np.ndarray,
    turned: np.ndarray,
    word_nibble: np.ndarray,
    word_errors: np.ndarray,
    word_flip: np.ndarray,
    registered: np.ndarray,
    only_registered: bool,
    min_contrast: float,
    max_border_errors: int,
    max_corrected_bits: int,
    max_flip_margin: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Decode Hampy-format candidates: one reading per candidate that reads as a marker.

    ``reading (N, 3 * 81 + 1)`` is :func:`.hamming._linear_reading`'s for each
    candidate: sharpened cells, the threshold under each, the black-white
    difference there, the contrast. A cell is white above its threshold, with
    a margin of the distance as a fraction of the difference. ``border``
    indexes the 32 border cells; ``turned[k]`` the 49 data cells, row by row,
    of the marker as printed when its top-left corner is the quad's corner k;
    the ``word_*`` tables decode a 7-bit row (:mod:`.hamming_code`);
    ``registered`` is the profile's ids, sorted. Returns ``(rows, turns, ids,
    corrected, ties)``: the candidate, the chosen corner k, its id, the bits
    corrected and how many turns tied for the best reading. The rules are the
    tracker's (see :class:`.hamming.HammingTracker`): registered ids first,
    then fewest corrections, then the smallest id.
    """
    n = reading.shape[0]
    n_cells = (reading.shape[1] - 1) // 3
    white = np.empty(n_cells, dtype=np.int64)
    margin = np.empty(n_cells)
    n_data = turned.shape[1]
    bits = int(round(math.sqrt(n_data)))
    refused_key = bits + 1  # corrections that can never be allowed
    no_key = 1 << 20
    rows = np.empty(n, dtype=np.int64)
    turns = np.empty(n, dtype=np.int64)
    ids_out = np.empty(n, dtype=np.int64)
    corrected_out = np.empty(n, dtype=np.int64)
    ties_out = np.empty(n, dtype=np.int64)
    keys = np.empty(4, dtype=np.int64)
    ids = np.empty(4, dtype=np.int64)
    corrections = np.empty(4, dtype=np.int64)
    all_white = (1 << (4 * bits)) - 1
    found = 0
    for m in range(n):
        if not reading[m, 3 * n_cells] >= min_contrast:
            continue
        for i in range(n_cells):
            above = reading[m, i] - reading[m, n_cells + i]
            white[i] = 1 if above > 0.0 else 0
            margin[i] = abs(above) / max(reading[m, 2 * n_cells + i], 1.0)
        border_white = 0
        for i in range(border.shape[0]):
            border_white += white[border[i]]
        inner = 0
        for i in range(n_data):
            inner += white[turned[0, i]]
        # hampy rejects all-black and all-white insides; so do we
        if border_white > max_border_errors or inner == 0 or inner == n_data:
            continue
        for k in range(4):
            marker_id = 0
            corrected = 0
            refused = False
            for r in range(bits):
                word = 0
                doubt = 1e300
                for c in range(bits):
                    cell = turned[k, r * bits + c]
                    word = 2 * word + white[cell]
                    doubt = min(doubt, margin[cell])
                marker_id = (marker_id << 4) | word_nibble[word]
                corrected += word_errors[word]
                flip = word_flip[word]
                # two misread (doubtful) cells in a row decode to a wrong nibble by
                # flipping a third, clearly read one: such a correction is refused
                if (
                    flip >= 0
                    and doubt < max_flip_margin
                    and margin[turned[k, r * bits + flip]] > max_flip_margin
                ):
                    refused = True
            # ids 0 and 2**28 - 1 are an all-black and an all-white inside
            if refused or marker_id == 0 or marker_id == all_white:
                corrected = refused_key
            ids[k] = marker_id
            corrections[k] = corrected
            is_registered = False
            if registered.shape[0]:
                at = np.searchsorted(registered, marker_id)
                is_registered = at < registered.shape[0] and registered[at] == marker_id
            valid = corrected <= max_corrected_bits and (is_registered or not only_registered)
            unregistered_penalty = 0 if is_registered else bits + 2
            keys[k] = unregistered_penalty + corrected if valid else no_key
        best = keys.min()
        if best == no_key:
            continue
        chosen = -1
        ties = 0
        for k in range(4):
            if keys[k] == best:
                ties += 1
                if chosen < 0 or ids[k] < ids[chosen]:
                    chosen = k
        rows[found] = m
        turns[found] = chosen
        ids_out[found] = ids[chosen]
        corrected_out[found] = corrections[chosen]
        ties_out[found] = ties
        found += 1
    return rows[:found], turns[:found], ids_out[:found], corrected_out[:found], ties_out[:found]


@compiled
def _twice_signed_area(quad: np.ndarray) -> float:
    """Twice the shoelace area of a quad ``(4, 2)``: positive when clockwise on screen (y down)."""
    twice = 0.0
    for k in range(4):
        j = (k + 1) % 4
        twice += quad[k, 0] * quad[j, 1] - quad[j, 0] * quad[k, 1]
    return twice


@compiled
def best_of_overlapping(
    quads: np.ndarray, corrected: np.ndarray, ambiguous: np.ndarray
) -> np.ndarray:
    """Indices (ascending) of the readings of quads ``(N, 4, 2)`` to keep.

    Of two whose centres are within half a side of each other (the larger's),
    the better reading wins: fewer bits corrected, then not ambiguous, then
    the larger.
    """
    n = quads.shape[0]
    area = np.empty(n)
    cx = np.empty(n)
    cy = np.empty(n)
    rank = np.empty(n)
    for i in range(n):
        area[i] = 0.5 * abs(_twice_signed_area(quads[i]))
        cx[i] = 0.25 * (quads[i, 0, 0] + quads[i, 1, 0] + quads[i, 2, 0] + quads[i, 3, 0])
        cy[i] = 0.25 * (quads[i, 0, 1] + quads[i, 1, 1] + quads[i, 2, 1] + quads[i, 3, 1])
    largest = area.max() if n else 0.0
    for i in range(n):
        # corrections, then ambiguity, then size; the area term stays below 1
        rank[i] = 4.0 * corrected[i] + 2.0 * ambiguous[i] - area[i] / (largest + 1.0)
    kept = np.zeros(n, dtype=np.bool_)
    for i in np.argsort(rank, kind="mergesort"):
        clear = True
        for j in range(n):
            if kept[j]:
                gap2 = (cx[i] - cx[j]) ** 2 + (cy[i] - cy[j]) ** 2
                if gap2 <= max(area[i], area[j]) / 4.0:
                    clear = False
                    break
        kept[i] = clear
    return np.flatnonzero(kept)


@compiled
def clockwise_quads(quads: np.ndarray, min_side: float) -> np.ndarray:
    """The quads ``(N, 4, 2)`` whose every side is at least ``min_side``, turned clockwise on screen.

    Clockwise with y down is a positive shoelace sum; a quad running the
    other way has its corners reversed.
    """
    keep = np.zeros(quads.shape[0], dtype=np.bool_)
    for m in range(quads.shape[0]):
        shortest = np.inf
        for k in range(4):
            j = (k + 1) % 4
            shortest = min(
                shortest,
                math.hypot(quads[m, j, 0] - quads[m, k, 0], quads[m, j, 1] - quads[m, k, 1]),
            )
        keep[m] = shortest >= min_side
    out = quads[keep].copy()
    for m in range(out.shape[0]):
        if _twice_signed_area(out[m]) < 0.0:
            out[m] = out[m, ::-1].copy()
    return out
