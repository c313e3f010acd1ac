"""The trackers' per-point work in whole-array numpy: grey levels, edge fits, cell reading.

A frame holds a handful of markers and each step of corner refinement and
cell reading is a small computation on a few thousand points. Each function
here takes every marker (or candidate) of a frame at once, so the number of
numpy calls per frame stays fixed whatever the number of markers: the cost
of a call, not the size of its arrays, is what such small arrays pay for.

Pixel coordinates are OpenCV's: x to the right, y down, pixel centres at
integers. Images are ``uint8``, grey ``(H, W)`` or BGR ``(H, W, 3)``.
Quads are ``(N, 4, 2)``, corner k followed by corner k + 1 around the square.
"""

from __future__ import annotations

import numpy as np

#: cv2.COLOR_BGR2GRAY's weights of the blue, green and red channels.
_BGR = np.array([0.114, 0.587, 0.299])


#: Corner k's neighbours around a quad: corner k + 1 and corner k - 1.
_NEXT = np.array([1, 2, 3, 0])
_PREVIOUS = np.array([3, 0, 1, 2])


def grey_at(image: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Bilinear grey levels ``(...)`` of ``image`` at ``points (..., 2)``, x then y (float64).

    Edge pixels repeat beyond the image, and a non-finite coordinate reads the
    nearest edge (NaN the first row or column), never memory outside the
    image. BGR pixels are weighed as ``cv2.cvtColor`` weighs them, unrounded.
    Interpolation is exact (``cv2.remap`` quantises positions to 1/32 px).
    """
    h, w = image.shape[0], image.shape[1]
    # fmax and fmin drop a NaN for the bound: NaN lands on the first pixel
    points = np.fmin(np.fmax(points, 0.0), (w - 1.0, h - 1.0))
    # the top-left neighbour stays one pixel inside the far edges, so all four neighbours
    # are pixels of the image; on the edge itself the far neighbour then weighs 1
    first = np.minimum(points.astype(np.intp), (max(w - 2, 0), max(h - 2, 0)))
    fraction = points - first
    step_x, step_y = min(w - 1, 1), w * min(h - 1, 1)
    corners = (first[..., 1] * w + first[..., 0])[..., None] + np.array(
        [0, step_x, step_y, step_x + step_y]
    )
    if image.ndim == 2:
        pixels = image.reshape(-1).take(corners).astype(np.float64)
    else:
        pixels = image.reshape(h * w, 3).take(corners.reshape(-1), axis=0).astype(np.float64)
        pixels = (pixels @ _BGR).reshape(corners.shape)
    pixels = pixels.reshape(*corners.shape[:-1], 2, 2)  # [..., row, column]
    rows = pixels[..., 0] + fraction[..., None, 0] * (pixels[..., 1] - pixels[..., 0])
    return rows[..., 0] + fraction[..., 1] * (rows[..., 1] - rows[..., 0])


def _refine_pass(
    image: np.ndarray,
    quads: np.ndarray,
    cells: float,
    along: np.ndarray,
    across: np.ndarray,
    weights: np.ndarray,
    min_contrast: float,
) -> tuple[np.ndarray, np.ndarray]:
    """One refinement pass of quads ``(M, 4)`` as complex ``x + iy``: refined corners, reach (px).

    See :mod:`.refine` for the method. Edge k runs from corner k to corner
    k + 1; corner k is where edges k - 1 and k meet. Points are complex
    numbers so that each step is one numpy call for both coordinates.
    """
    edge = quads[:, _NEXT] - quads  # (M, 4)
    lengths = np.abs(edge)
    side = 0.25 * lengths.sum(axis=1)  # (M,)
    reach = np.minimum(np.maximum(0.8 / cells * side, 0.8), 4.0)
    # outward normal of a clockwise quad (y down), one reach long: -i times the edge
    normal = edge * (-1j * reach[:, None] / np.maximum(lengths, 1e-9))
    base = quads[..., None] + edge[..., None] * along  # (M, 4, T): points along each edge
    points = base[..., None] + normal[..., None, None] * across  # (M, 4, T, S)
    # a short profile across the edge; complex128 viewed as (x, y) pairs of float64
    profile = grey_at(image, points.view(np.float64).reshape(*points.shape, 2))
    dark = 0.5 * (profile[..., 0] + profile[..., 1])
    contrast = 0.5 * (profile[..., -2] + profile[..., -1]) - dark
    ok = contrast > min_contrast  # (M, 4, T)
    fraction = (profile - dark[..., None]) / np.where(ok, contrast, 1.0)[..., None]
    # e = w - integral of the light fraction over [-w, w], in units of reach
    light = np.minimum(np.maximum(fraction, 0.0), 1.0).reshape(-1, len(weights)) @ weights
    e = 1.0 - light.reshape(ok.shape)
    found = np.where(ok, base + e * normal[..., None], 0.0)
    count = ok.sum(axis=-1)  # (M, 4)
    mean = found.sum(axis=-1) / np.maximum(count, 1)
    spread = np.where(ok, found - mean[..., None], 0.0)
    # total-least-squares line: its direction is half the angle of sum((r_x + i r_y)^2)
    squares = (spread * spread).sum(axis=-1)
    direction = np.exp(0.5j * np.arctan2(squares.imag, squares.real))
    # corner k: the line of edge k - 1 (through p along v) meets that of edge k
    p, v = mean[:, _PREVIOUS], direction[:, _PREVIOUS]
    denom = (v.conjugate() * direction).imag  # cross(v, u)
    fitted = count >= 4
    usable = fitted & fitted[:, _PREVIOUS] & (np.abs(denom) >= 1e-6)
    corner = p + v * ((mean - p).conjugate() * direction).imag / np.where(usable, denom, 1.0)
    limit = 2.0 / cells * side  # a corner that jumps more than two cells is a failed fit
    usable &= np.abs(corner - quads) < limit[:, None]
    return np.where(usable, corner, quads), reach


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
    quads = np.asarray(quads, dtype=np.float64)
    current = quads[..., 0] + 1j * quads[..., 1]
    from_centre = current - current.mean(axis=1, keepdims=True)
    current += from_centre * (inset * np.sqrt(2.0) / np.maximum(np.abs(from_centre), 1e-6))
    active = np.arange(len(quads))
    for _ in range(passes):
        if len(active) == 0:
            break
        before = current[active]
        refined, reach = _refine_pass(image, before, cells, along, across, weights, min_contrast)
        current[active] = refined
        # a profile that ended within the blur of the edge biases the fit: once more
        active = active[np.abs(refined - before).max(axis=1) > 0.3 * reach]
    return np.stack([current.real, current.imag], axis=-1)


def unit_square_homographies(quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The projective maps ``(N, 3, 3)`` of the unit square onto quads ``(N, 4, 2)``:
    ``H @ (u, v, 1)`` is ``(x w, y w, w)``, (0,0), (1,0), (1,1), (0,1) going to corners
    0 to 3, in closed form (Heckbert 1989, square to quadrilateral); and which quads are
    degenerate ``(N,)`` (no such map: theirs is then not one of the quad)."""
    quads = np.asarray(quads, dtype=np.float64)
    (x0, y0), (x1, y1), (x2, y2), (x3, y3) = (quads[:, k].T for k in range(4))
    dx1, dx2, dx3 = x1 - x2, x3 - x2, x0 - x1 + x2 - x3
    dy1, dy2, dy3 = y1 - y2, y3 - y2, y0 - y1 + y2 - y3
    den = dx1 * dy2 - dx2 * dy1
    degenerate = np.abs(den) < 1e-12
    den = np.where(degenerate, 1.0, den)
    g = (dx3 * dy2 - dx2 * dy3) / den
    h = (dx1 * dy3 - dx3 * dy1) / den
    columns = [
        np.stack([x1 - x0 + g * x1, y1 - y0 + g * y1, g], axis=1),
        np.stack([x3 - x0 + h * x3, y3 - y0 + h * y3, h], axis=1),
        np.stack([x0, y0, np.ones_like(x0)], axis=1),
    ]
    return np.stack(columns, axis=2), degenerate


def sample_cells(
    image: np.ndarray, quads: np.ndarray, cell_uv: np.ndarray, quiet_uv: np.ndarray
) -> np.ndarray:
    """Grey levels ``(N, C + Q)`` of each quad ``(N, 4, 2)``'s cells, then of its quiet zone.

    ``cell_uv (C, S, 2)`` are S points in each of C cells, ``quiet_uv (Q, 2)``
    single points, all on the unit square, which is mapped onto each quad
    projectively (:func:`unit_square_homographies`). A cell's level is the mean of
    its points. A degenerate quad reads its first corner's level everywhere.
    """
    quads = np.asarray(quads, dtype=np.float64)
    n_cells, per_cell = cell_uv.shape[0], cell_uv.shape[1]
    homography, degenerate = unit_square_homographies(quads)
    uv = np.concatenate([cell_uv.reshape(-1, 2), quiet_uv])
    mapped = uv[:, 0, None] * homography[:, None, :, 0] + uv[:, 1, None] * homography[:, None, :, 1]
    mapped += homography[:, None, :, 2]  # (N, P, 3): x w, y w, w
    w = mapped[..., 2:]
    levels = grey_at(image, mapped[..., :2] / np.where(np.abs(w) < 1e-12, 1e-12, w))
    split = n_cells * per_cell
    out = np.concatenate(
        [
            levels[:, :split].reshape(-1, n_cells, per_cell).sum(axis=-1) / per_cell,
            levels[:, split:],
        ],
        axis=1,
    )
    if degenerate.any():
        out[degenerate] = grey_at(image, quads[degenerate, :1])
    return out


def framed_by_light(image: np.ndarray, quads: np.ndarray, cells: int) -> np.ndarray:
    """How much lighter than its border the ring just outside each quad ``(N, 4, 2)`` is, as
    a fraction of the border's contrast with its lightest inner cell (``cells`` a side,
    border included): about 1 for a printed marker in its white quiet zone, about 0 for a
    dark patch of the scene around a light blob, which a detector can read as a marker."""
    quads = np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2)
    if len(quads) == 0:
        return np.zeros(0)
    centres = np.arange(cells) + 0.5
    middle = (np.stack(np.meshgrid(centres, centres), axis=-1).reshape(-1, 1, 2)) / cells
    out, side = -0.5 / cells, 1.0 + 0.5 / cells
    along = centres / cells
    ring = np.concatenate(
        [
            np.column_stack([along, np.full(cells, out)]),
            np.column_stack([np.full(cells, side), along]),
            np.column_stack([along, np.full(cells, side)]),
            np.column_stack([np.full(cells, out), along]),
        ]
    )
    levels = sample_cells(image, quads, middle, ring)
    grid = levels[:, : cells * cells].reshape(-1, cells, cells)
    border = np.concatenate(
        [grid[:, 0], grid[:, -1], grid[:, 1:-1, 0], grid[:, 1:-1, -1]], axis=1
    ).mean(axis=1)
    lightest = grid[:, 1:-1, 1:-1].reshape(len(quads), -1).max(axis=1)
    quiet = np.median(levels[:, cells * cells :], axis=1)
    return (quiet - border) / np.maximum(lightest - border, 1e-6)


def read_markers(
    reading: np.ndarray,
    border: np.ndarray,
    turned: np.ndarray,
    codewords: np.ndarray,
    registered: np.ndarray,
    only_registered: bool,
    min_contrast: float,
    max_border_errors: int,
    max_corrected_bits: int,
    max_flip_margin: float,
    min_row_gap: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Decode Hampy-format candidates: one reading per candidate that reads as a marker.

    ``reading (N, 3 * 81 + 1)`` is :func:`.hamming._linear_reading`'s for each
    candidate: sharpened cells, the threshold under each, the black-white
    difference there, the contrast. A cell is white above its threshold, with
    a margin of the distance as a fraction of the difference. ``border``
    indexes the 32 border cells; ``turned[k]`` the 49 data cells, row by row,
    of the marker as printed when its top-left corner is the quad's corner k;
    ``codewords (16, 7)`` the Hamming(7,4) code word of each nibble
    (:mod:`.hamming_code`); ``registered`` is the profile's ids, sorted.

    Each row is decoded by soft decision: the code word whose cells that
    disagree with the reading weigh least, each weighing its margin. A row is
    trusted when that code word beats every other by ``min_row_gap`` (summed
    margins) and it flips only doubtful cells (margins below
    ``max_flip_margin``): a clear cell read wrong is an occluder or another
    marker, not noise. The bits flipped over the seven rows are the
    corrections, at most ``max_corrected_bits``.

    Returns ``(rows, turns, ids, corrected, ties, unread)``: the candidate, the
    chosen corner k, its id, the bits corrected and how many turns tied for the
    best reading; and the candidates that look like markers (contrast, a black
    border, an inside neither all black nor all white) but decode as no id
    under any turn. The rules are the tracker's (see
    :class:`.hamming.HammingTracker`): registered ids first, then fewest
    corrections, then the smallest id.
    """
    n_cells = (reading.shape[1] - 1) // 3
    n_data = turned.shape[1]
    bits = int(round(np.sqrt(n_data)))
    rows = np.flatnonzero(reading[:, 3 * n_cells] >= min_contrast)
    above = reading[rows, :n_cells] - reading[rows, n_cells : 2 * n_cells]
    white = above > 0.0
    margin = np.abs(above) / np.maximum(reading[rows, 2 * n_cells : 3 * n_cells], 1.0)
    inner = white[:, turned[0]].sum(axis=1)
    # hampy rejects all-black and all-white insides; so do we
    plausible = (white[:, border].sum(axis=1) <= max_border_errors) & (inner > 0)
    plausible &= inner < n_data
    rows, white, margin = rows[plausible], white[plausible], margin[plausible]
    # each candidate's data cells under the four turns, row by row: (N, 4, 7, 7)
    shape = (len(rows), 4, bits, bits)
    cells = white[:, turned].reshape(shape)
    doubts = margin[:, turned].reshape(shape)
    # every row against every code word: the cells that disagree and what they weigh
    disagree = cells[..., None, :] != codewords.astype(bool)  # (N, 4, 7, 16, 7)
    cost = (disagree * doubts[..., None, :]).sum(axis=-1)  # (N, 4, 7, 16)
    order = np.argsort(cost, axis=-1, kind="stable")[..., :2]
    nibbles = order[..., 0]
    best, second = np.moveaxis(np.take_along_axis(cost, order, axis=-1), -1, 0)
    flips = np.take_along_axis(disagree, nibbles[..., None, None], axis=-2)[..., 0, :]
    ids = nibbles @ (1 << (4 * np.arange(bits - 1, -1, -1)))  # (N, 4)
    corrected = flips.sum(axis=(-1, -2))
    refused = (flips & (doubts >= max_flip_margin)).any(axis=(-1, -2))
    refused |= (second - best < min_row_gap).any(axis=-1)
    # ids 0 and 2**28 - 1 are an all-black and an all-white inside
    refused |= (ids == 0) | (ids == (1 << (4 * bits)) - 1)
    corrected = np.where(refused, n_data + 1, corrected)  # a count never allowed
    unread = rows[~(corrected <= max_corrected_bits).any(axis=1)]
    if len(registered):  # sorted
        at = np.minimum(np.searchsorted(registered, ids), len(registered) - 1)
        is_registered = registered[at] == ids
    else:
        is_registered = np.zeros(ids.shape, dtype=bool)
    valid = (corrected <= max_corrected_bits) & (is_registered | (not only_registered))
    no_key = 1 << 20
    keys = np.where(valid, np.where(is_registered, 0, n_data + 2) + corrected, no_key)
    best_key = keys.min(axis=1, initial=no_key)
    tied = keys == best_key[:, None]
    chosen = np.argmin(np.where(tied, ids, np.iinfo(np.int64).max), axis=1)
    found = best_key < no_key
    pick = np.arange(len(rows))[found], chosen[found]
    return (
        rows[found],
        chosen[found],
        ids[pick],
        corrected[pick],
        tied.sum(axis=1)[found],
        unread,
    )


def twice_signed_area(quads: np.ndarray) -> np.ndarray:
    """Twice the shoelace areas of quads ``(..., 4, 2)``: positive when clockwise on screen (y down)."""
    quads = np.asarray(quads, dtype=np.float64)
    following = quads[..., _NEXT, :]
    return (quads[..., 0] * following[..., 1] - following[..., 0] * quads[..., 1]).sum(axis=-1)


def best_of_overlapping(
    quads: np.ndarray, corrected: np.ndarray, ambiguous: np.ndarray
) -> np.ndarray:
    """Indices (ascending) of the readings of quads ``(N, 4, 2)`` to keep.

    Of two whose centres are within half a side of each other (the larger's),
    the better reading wins: fewer bits corrected, then not ambiguous, then
    the larger.
    """
    n = len(quads)
    if n == 0:
        return np.zeros(0, dtype=np.intp)
    area = 0.5 * np.abs(twice_signed_area(quads))
    centres = np.asarray(quads, dtype=np.float64).mean(axis=1)
    # corrections, then ambiguity, then size; the area term stays below 1
    rank = 4.0 * np.asarray(corrected) + 2.0 * np.asarray(ambiguous) - area / (area.max() + 1.0)
    gap2 = ((centres[:, None, :] - centres[None, :, :]) ** 2).sum(axis=-1)
    overlapping = gap2 <= np.maximum(area[:, None], area[None, :]) / 4.0
    kept = np.zeros(n, dtype=bool)
    for i in np.argsort(rank, kind="stable"):
        kept[i] = not (overlapping[i] & kept).any()
    return np.flatnonzero(kept)


def apart_from(quads: np.ndarray, markers: np.ndarray) -> np.ndarray:
    """Which of ``quads (N, 4, 2)`` neither hold a marker of ``markers (M, 4, 2)`` nor lie in
    one (no centre of either inside the other): a marker's label or mount, or a contour of
    its cells, is not another marker-like shape."""
    quads = np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2)
    markers = np.asarray(markers, dtype=np.float64).reshape(-1, 4, 2)
    if len(quads) == 0 or len(markers) == 0:
        return np.ones(len(quads), dtype=bool)
    inside = _contains(quads, markers.mean(axis=1)) | _contains(markers, quads.mean(axis=1)).T
    return ~inside.any(axis=1)


def _contains(quads: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``(N, P)``: point p inside convex quad n (either winding)."""
    edges = quads[:, _NEXT] - quads  # (N, 4, 2)
    to = points[None, None, :, :] - quads[:, :, None, :]  # (N, 4, P, 2)
    cross = edges[..., None, 0] * to[..., 1] - edges[..., None, 1] * to[..., 0]
    return (cross >= 0).all(axis=1) | (cross <= 0).all(axis=1)


def clockwise_quads(quads: np.ndarray, min_side: float) -> np.ndarray:
    """The quads ``(N, 4, 2)`` whose every side is at least ``min_side``, turned clockwise on screen.

    Clockwise with y down is a positive shoelace sum; a quad running the
    other way has its corners reversed.
    """
    corners = quads.astype(np.float64)
    edges = corners[:, _NEXT] - corners
    shortest = np.sqrt((edges * edges).sum(axis=-1).min(axis=1, initial=np.inf))
    out = quads[shortest >= min_side]
    backwards = twice_signed_area(out) < 0.0
    out[backwards] = out[backwards, ::-1]
    return out
