"""Reading a small, blurred Hampy marker by fitting blurred code words to it, row by row.

At 16 px a side a Hampy marker has under two pixels a cell, and a pixel of defocus
blur spreads every cell over its neighbours: no threshold reads the cells one by
one. :mod:`.blur_decode` reads such ArUco and AprilTag markers by fitting every
word of their dictionary, blurred, to the candidate; a Hampy id has 28 bits, far
too many words for that. But each printed row is a Hamming(7,4) code word of its
own, so the fit can be made row by row: the predicted grey levels of a print are
linear in its cells (black border, white quiet zone, Gaussian blur as a separable
sum of normal CDF differences over each cell's box), and after an unknown black
level, contrast and linear light gradient are fitted away, replacing one row's
word changes the fit's correlation in closed form (:func:`_row_search`).

A candidate is read in two steps:

* a first reading on a grid of points over its quad, its sides moved
  :data:`INSET_PX` in, for each of the four turns and a few blur widths
  (:data:`BLUR_CELLS`; their predictions are the same for every candidate, so
  they are tabled once): starting from a grey inside, every row in turn takes the
  word of its 16 that fits best, until no row changes. It finds the turn and most
  rows, but the search's corners sit a few tenths of a pixel off a blurred border
  and sampling between pixels blurs the levels once more, so a right reading fits
  with a correlation of only 0.93-0.99 and a wrong one not much worse;
* a candidate whose first reading is a valid id fitting at least
  :data:`REFINE_MIN_FIT` is then fitted on its own pixels (:class:`_PixelFit`):
  each pixel's predicted level is the blurred print at the point the quad's
  homography maps it to, and Gauss-Newton steps move the four corners and the blur
  width to fit the reading; the rows are then read again from those pixels. With
  the corners to 0.04 px and the blur width to 1 %, a right reading fits with a
  correlation of 0.99-0.999, which noise (2-4 grey levels against 190 of
  contrast) leaves it.

The refined reading is kept only when it fits well (:data:`MIN_FIT`) and much
better than the nearest other reading, the best fit with one row's word changed
(:data:`MIN_GAP`, the ratio of unexplained variances), and when its id is a valid
marker (:func:`.hamming_code.id_problem`; its other turns are then far from any
valid id). Two code words of a row differ in at least three cells, so that second
reading is the one a wrong id would have to beat.
"""

from __future__ import annotations

import functools

import numpy as np

from .blur_decode import cell_spread, clear_readings, light_basis, sample_grid
from .hamming_code import BITS, CODEWORDS, GRID, REFUSED_IDS, id_problem
from .kernels import sample_cells, unit_square_homographies

#: Least correlation between a candidate's pixels and its refined reading's prediction
#: (a right reading: 0.986 or more in nine of ten, at 12-32 px in the benchmark's frames).
MIN_FIT = 0.975
#: Least ratio of the unexplained variance of the nearest other reading to the best's. In
#: 20,000 benchmark frames the valid wrong readings reached 1.8 on uncovered markers and
#: 2.7 on one partly covered (which :data:`MAX_UNEVENNESS` refuses); 2.5 would cost a
#: tenth of the readings in the hard frames.
MIN_GAP = 2.2
#: Most a refined reading's misfit may gather in one part of the marker
#: (:meth:`_PixelFit._unevenness`; 1.4 for noise, 2.4 at most in 99 of 100 right readings,
#: 3-6 for the wrong readings of partly covered markers in 20,000 benchmark frames).
MAX_UNEVENNESS = 3.0
#: Least correlation of a first reading for its candidate to be refined.
REFINE_MIN_FIT = 0.85
#: Blur widths of the first reading (sd, in cells): from a sharp print to a pixel of
#: blur at 1.8 px a cell.
BLUR_CELLS = (0.3, 0.5, 0.7)
#: Sweeps over the seven rows at most (the first reading seldom changes after the second).
SWEEPS = 3
#: How far in (px) the first reading reads each side of a candidate: the candidate
#: search's corners sit a few tenths of a pixel outside a blurred marker's border
#: (0.13 px on average at 16-20 px).
INSET_PX = 0.15
#: Gauss-Newton steps on the corners and the blur width (two converge from the
#: search's corners), and again after the rows' reading changed.
REFINE_STEPS = (2, 1)
#: How far outside the black border (cells) the refinement reads pixels: the quiet
#: zone is 1.5 cells wide and the scene beyond it must not blur into what is read.
MARGIN_CELLS = 0.5
#: Blur (sd, px) the refinement starts from: the benchmark's defocus and the pixels' own
#: area together are 0.6-1.1 px.
START_BLUR_PX = 0.9
#: Fewest pixels of a candidate in the frame for it to be refined.
MIN_PIXELS = 64

_PRINTED = GRID + 2  # the marker and a ring of quiet zone around it
_WORDS = CODEWORDS.astype(np.float64)  # (16, 7)
_SHIFTS = 4 * np.arange(BITS - 1, -1, -1)
_DATA = BITS * BITS  # the 49 data cells, row by row as printed
_BOUNDS = np.arange(GRID + 1.0)  # cell boundaries along a side, in cells from the border's edge
_CORNERS = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0]])
_SQRT_2_PI = np.sqrt(2.0 / np.pi)


def _turned_cells() -> np.ndarray:
    """For each turn k, the printed grid's cell of each data cell, row by row as printed,
    when the marker's top-left corner is the quad's corner k (as :mod:`.hamming` turns)."""
    inner = np.arange(GRID * GRID).reshape(GRID, GRID)[1:-1, 1:-1]
    out = []
    for k in range(4):
        cells = np.rot90(inner, k).ravel()
        row, col = np.divmod(cells, GRID)
        out.append((row + 1) * _PRINTED + col + 1)
    return np.stack(out)


def _own_terms(gram: np.ndarray) -> np.ndarray:
    """``(..., 7, 16)``: each code word's own term of the squared norm, in each row, of
    fits with the inner products ``gram (..., 50, 50)`` (:func:`_row_search`)."""
    data = gram[..., :_DATA, :_DATA].reshape(*gram.shape[:-2], BITS, BITS, BITS, BITS)
    blocks = np.stack([data[..., r, :, r, :] for r in range(BITS)], axis=-3)  # (..., 7, 7, 7)
    return ((blocks @ _WORDS.T) * _WORDS.T).sum(axis=-2)


def _row_search(
    g: np.ndarray, gram: np.ndarray, own: np.ndarray, start: np.ndarray | None, sweeps: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows' code words that fit best, each row in turn, for many fits at once.

    A fit's prediction is ``x @ cells``: the unlit, unit-free predictions of its 49 data
    cells (row by row as printed) and, last, of everything else of the print (black
    border, white quiet zone), ``x`` the data cells' whites (1) and 1 for the rest. Its
    correlation with the candidate's unlit levels is ``g.x / sqrt(x.gram.x)``, with
    ``g (..., 50)`` the cells' inner products with the levels and ``gram (..., 50, 50)``
    theirs with each other, ``own`` their :func:`_own_terms`. ``start (..., 7)`` are the
    nibbles to start from (None: a grey inside). Returns the nibbles ``(..., 7)``, their correlation ``(...)`` and that of the
    nearest other reading, one row at its second-best word ``(...)``.
    """
    shape = np.broadcast_shapes(g.shape, gram.shape[:-1])
    x = np.ones(shape)
    x[..., :_DATA] = 0.5 if start is None else _WORDS[start].reshape(*shape[:-1], _DATA)
    words = np.full(shape[:-1] + (BITS,), -1) if start is None else start.copy()
    gx = (gram @ x[..., None])[..., 0]  # the gram matrix times x, kept up to date
    scores = np.zeros(shape[:-1] + (BITS, 16))
    for _ in range(sweeps):
        changed = False
        for r in range(BITS):
            rows = slice(BITS * r, BITS * (r + 1))
            # the fit with row r emptied: its correlation's numerator and squared norm
            gy = gx - (gram[..., rows] @ x[..., rows, None])[..., 0]
            y = x.copy()
            y[..., rows] = 0.0
            num = (g * y).sum(-1)[..., None] + g[..., rows] @ _WORDS.T
            den = (gy * y).sum(-1)[..., None] + 2.0 * gy[..., rows] @ _WORDS.T + own[..., r, :]
            score = num / np.sqrt(np.maximum(den, 1e-12))
            best = score.argmax(axis=-1)
            scores[..., r, :] = score
            changed |= bool((best != words[..., r]).any())
            words[..., r] = best
            x[..., rows] = _WORDS[best]
            gx = gy + (gram[..., rows] @ x[..., rows, None])[..., 0]
        if not changed:
            break
    top = scores[..., BITS - 1, :].max(axis=-1)  # the last row saw every other final
    second = np.sort(scores, axis=-1)[..., -2].max(axis=-1)
    return words, top, second


def _ids(nibbles: np.ndarray) -> np.ndarray:
    """The ids ``(...)`` of rows' nibbles ``(..., 7)``."""
    return (nibbles << _SHIFTS).sum(axis=-1)


def _valid(ids: np.ndarray) -> np.ndarray:
    """Which ``ids`` are markers a clean print reads as (:func:`.hamming_code.id_problem`)."""
    return np.array([int(i) not in REFUSED_IDS and id_problem(int(i)) is None for i in ids], bool)


class HammingBlurReader:
    """Reads Hampy candidates whose cells are too small and blurred to threshold."""

    def __init__(self) -> None:
        x, self._uv = sample_grid(GRID)
        light = light_basis(self._uv)
        unlight = np.eye(len(light)) - light @ np.linalg.pinv(light)  # removes light
        self._light, self._light_fit = light, np.linalg.pinv(light)
        fixed = np.ones((_PRINTED, _PRINTED))
        fixed[1:-1, 1:-1] = 0.0  # border (and the inside, given by the words) black
        turned = _turned_cells()
        cells = []
        for sd in BLUR_CELLS:
            spread = cell_spread(x, GRID, sd)
            predict = unlight @ np.kron(spread, spread)  # (points, printed cells), unlit
            base = predict @ fixed.ravel()
            cells.append([np.column_stack([predict[:, t], base]) for t in turned])
        #: (blur widths, turns, points, 50): the unlit predictions of the data cells and the rest
        self._cells = np.array(cells)
        self._gram = np.einsum("skpc,skpd->skcd", self._cells, self._cells)
        self._own = _own_terms(self._gram)

    def levels(self, gray: np.ndarray, quads: np.ndarray, inset_px: float = 0.0) -> np.ndarray:
        """Each quad's grey levels at the first reading's points, each side moved
        ``inset_px`` in, light removed, of unit length."""
        quads = np.asarray(quads, np.float64)
        if inset_px:
            centres = quads.mean(axis=1, keepdims=True)
            sides = np.linalg.norm(quads - np.roll(quads, 1, axis=1), axis=2).mean(axis=1)
            shrink = np.clip(1.0 - 2.0 * inset_px / np.maximum(sides, 1e-9), 0.5, 1.0)
            quads = centres + (quads - centres) * shrink[:, None, None]
        raw = sample_cells(gray, quads, self._uv, np.zeros((0, 2)))
        unlit = raw - (raw @ self._light_fit.T) @ self._light.T
        return unlit / np.maximum(np.linalg.norm(unlit, axis=1, keepdims=True), 1e-9)

    def fit(self, levels: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The best first reading of each candidate's ``levels (N, points)``: its rows'
        nibbles ``(N, 7)``, turn ``(N,)``, and its correlation with the nearest other
        reading's (one row's word changed, or another turn) ``(N, 2)``."""
        n = len(levels)
        g = np.einsum("skpc,np->nskc", self._cells, levels)  # (n, widths, turns, 50)
        words, top, second = _row_search(g, self._gram[None], self._own[None], None, SWEEPS)
        top, second = top.reshape(n, -1), second.reshape(n, -1)
        best = top.argmax(axis=1)
        turn_of = np.tile(np.arange(4), len(BLUR_CELLS))
        best_turn = turn_of[best]
        rows = np.arange(n)
        other_turn = np.where(turn_of[None] != best_turn[:, None], top, -np.inf).max(axis=1)
        scores = np.column_stack([top[rows, best], np.maximum(second[rows, best], other_turn)])
        return words.reshape(n, -1, BITS)[rows, best], best_turn, scores

    def read(
        self, gray: np.ndarray, quads: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each quad's id and turn ``(N,)``, ``-1`` where no reading fits as this module
        asks, and its corners ``(N, 4, 2)``: refined, in printed order (the marker's
        top-left first), where it was read; as given elsewhere."""
        quads = np.asarray(quads, np.float64).reshape(-1, 4, 2)
        count = len(quads)
        ids, turns, corners = np.full(count, -1), np.full(count, -1), quads.copy()
        if count == 0:
            return ids, turns, corners
        gray = np.ascontiguousarray(gray)
        nibbles, turn, scores = self.fit(self.levels(gray, quads, INSET_PX))
        picked = np.flatnonzero((scores[:, 0] >= REFINE_MIN_FIT) & _valid(_ids(nibbles)))
        if len(picked) == 0:
            return ids, turns, corners
        # corner 0 the print's top-left, so that the pixel fit reads the rows as printed
        printed = quads[picked[:, None], (turn[picked, None] + np.arange(4)) % 4]
        pixels = _PixelFit(gray, printed)
        nibbles, top, second, uneven = pixels.read(nibbles[picked])
        read = clear_readings(top, second, MIN_FIT, MIN_GAP) & (uneven <= MAX_UNEVENNESS)
        read &= pixels.enough
        found = _ids(nibbles)
        read[read] = _valid(found[read])
        ids[picked[read]], turns[picked[read]] = found[read], turn[picked[read]]
        corners[picked[read]] = pixels.corners()[read]
        return ids, turns, corners


def _normal_cdf(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The standard normal CDF at ``z`` and its slope, by the tanh approximation (within
    2e-4 of it, far below noise; ``scipy.special.ndtr`` costs twenty times as much)."""
    t = np.tanh(_SQRT_2_PI * z * (1.0 + 0.044715 * z * z))
    slope = (0.5 * _SQRT_2_PI) * (1.0 - t * t) * (1.0 + 0.134145 * z * z)
    return 0.5 + 0.5 * t, slope


def _spread(cdf: np.ndarray) -> np.ndarray:
    """``(..., 11)``: how much of each printed cell along a side a point takes, from the
    blur's CDF at the 10 cell boundaries ``(..., 10)`` (the two quiet-zone cells reach
    out for ever)."""
    out = np.empty(cdf.shape[:-1] + (_PRINTED,))
    out[..., 0] = 1.0 - cdf[..., 0]
    out[..., 1:-1] = cdf[..., :-1] - cdf[..., 1:]
    out[..., -1] = cdf[..., -1]
    return out


def _spread_change(slope: np.ndarray) -> np.ndarray:
    """:func:`_spread`'s change ``(..., 11)`` for changes ``(..., 10)`` of the CDF at the
    boundaries."""
    out = np.empty(slope.shape[:-1] + (_PRINTED,))
    out[..., 0] = -slope[..., 0]
    out[..., 1:-1] = slope[..., :-1] - slope[..., 1:]
    out[..., -1] = slope[..., -1]
    return out


def _printed_grids(nibbles: np.ndarray) -> np.ndarray:
    """``(N, 11, 11)``: each reading's print, 1 white: quiet zone, border, data rows."""
    grids = np.ones((len(nibbles), _PRINTED, _PRINTED))
    grids[:, 1:-1, 1:-1] = 0.0
    grids[:, 2:-2, 2:-2] = _WORDS[nibbles]
    return grids


class _PixelFit:
    """Candidates fitted on their own pixels: corners, blur and rows, a batch at once.

    ``quads (N, 4, 2)`` (px) run from the print's top-left corner. A pixel's marker
    coordinates (u along the top row, v down the left column, in cells from the
    border's outer edge) are its position mapped through the inverse of the quad's
    homography, ``(I + D) H^-1`` after each Gauss-Newton step ``D``; its predicted level
    is the print blurred by a Gaussian, separable along u and v with the widths in cells
    of the blur's px width at the quad's centre, plus a black level and a linear light
    gradient. Pixels are read at whole positions (OpenCV's pixel centres): no
    interpolation blurs them further.
    """

    def __init__(self, gray: np.ndarray, quads: np.ndarray) -> None:
        self._centre = quads.mean(axis=1)
        # positions relative to each centre keep the homographies well conditioned
        homographies, degenerate = unit_square_homographies(quads - self._centre[:, None])
        #: Which candidates the fit can read: a square, with enough pixels in the frame.
        self.enough = ~degenerate & (np.abs(np.linalg.det(homographies)) > 1e-9)
        homographies[~self.enough] = np.eye(3)
        self._inverse = np.linalg.inv(homographies)
        self._log_blur = np.full(len(quads), np.log(START_BLUR_PX))
        self._gather(gray, quads)
        self.enough &= self._weight.sum(axis=1) >= MIN_PIXELS

    def _gather(self, gray: np.ndarray, quads: np.ndarray) -> None:
        """Each candidate's pixels within :data:`MARGIN_CELLS` of its square, first in a
        row of the same length for every candidate (the rest weighing 0); their
        positions from its centre, and their levels, light removed, of unit length."""
        low = np.floor(quads.min(axis=1)).astype(int) - 2
        width = int((np.ceil(quads.max(axis=1)).astype(int) + 2 - low).max()) + 1
        dy, dx = np.divmod(np.arange(width * width), width)
        x, y = low[:, :1] + dx, low[:, 1:] + dy
        h, w = gray.shape
        self._at = np.stack([x - self._centre[:, :1], y - self._centre[:, 1:]], axis=-1)
        u, v = self._marker_uv()
        m = MARGIN_CELLS
        keep = (x >= 0) & (x < w) & (y >= 0) & (y < h)
        keep &= (u >= -m) & (u <= GRID + m) & (v >= -m) & (v <= GRID + m)
        order = np.argsort(~keep, axis=1, kind="stable")[:, : max(int(keep.sum(axis=1).max()), 1)]
        self._weight = np.take_along_axis(keep, order, 1).astype(np.float64)
        self._at = np.take_along_axis(self._at, order[..., None], 1)
        x, y = np.take_along_axis(x, order, 1), np.take_along_axis(y, order, 1)
        levels = gray[np.clip(y, 0, h - 1), np.clip(x, 0, w - 1)] * self._weight
        ones = self._weight
        light = np.stack([ones, ones * self._at[..., 0] / 10.0, ones * self._at[..., 1] / 10.0], -1)
        self._light = np.linalg.qr(light)[0]  # (N, pixels, 3), orthonormal
        unlit = self._unlit(levels[..., None])[..., 0]
        self._levels = unlit / np.maximum(np.linalg.norm(unlit, axis=1, keepdims=True), 1e-9)

    def _unlit(self, values: np.ndarray) -> np.ndarray:
        """``values (N, pixels, K)`` less their best fit of a black level and a gradient."""
        return values - self._light @ (self._light.transpose(0, 2, 1) @ values)

    def _marker_uv(self) -> tuple[np.ndarray, np.ndarray]:
        """The pixels' marker coordinates (cells); keeps them on the unit square as well."""
        mapped = (
            self._at @ self._inverse[:, :, :2].transpose(0, 2, 1) + self._inverse[:, None, :, 2]
        )
        self._s, self._t = mapped[..., 0] / mapped[..., 2], mapped[..., 1] / mapped[..., 2]
        return GRID * self._s, GRID * self._t

    def _blur_cells(self) -> np.ndarray:
        """``(N, 2)``: the blur's sd in cells along u and along v at each quad's centre."""
        forward = np.linalg.inv(self._inverse)
        centre = forward @ np.array([0.5, 0.5, 1.0])  # (N, 3)
        w = centre[:, 2, None, None]
        # d(x, y) / d(s, t) of the projective map at the centre, per cell
        jac = (forward[:, :2, :2] - centre[:, :2, None] / w * forward[:, 2, None, :2]) / w / GRID
        det = jac[:, 0, 0] * jac[:, 1, 1] - jac[:, 0, 1] * jac[:, 1, 0]
        # the marginal sds of an isotropic blur mapped into marker coordinates
        along = np.stack(
            [np.hypot(jac[:, 1, 1], jac[:, 0, 1]), np.hypot(jac[:, 1, 0], jac[:, 0, 0])], 1
        )
        return np.exp(self._log_blur)[:, None] * along / np.maximum(np.abs(det), 1e-9)[:, None]

    def _spreads(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each pixel's share of each printed cell along u and along v ``(N, pixels, 2, 11)``,
        and how it changes with the pixel's u or v and with the log of the blur width."""
        u, v = self._marker_uv()
        sd = self._blur_cells()[:, None, :, None]  # (N, 1, 2, 1)
        z = (np.stack([u, v], axis=-1)[..., None] - _BOUNDS) / sd  # (N, pixels, 2, 10)
        cdf, slope = _normal_cdf(z)
        return _spread(cdf), _spread_change(slope / sd), _spread_change(-slope * z)

    def _jacobian(self, nibbles: np.ndarray) -> np.ndarray:
        """``(N, pixels, 10)``, unlit: how the prediction of the prints of ``nibbles (N, 7)``
        changes with the 8 free entries of a step ``D`` of the inverse homography and with
        the log of the blur width, and last the prediction itself."""
        across = _printed_grids(nibbles).transpose(0, 2, 1)  # (N, 11 along u, 11 along v)
        spread, by_place, by_blur = self._spreads()
        su, sv = spread[..., 0, :], spread[..., 1, :]
        rows = su @ across  # each printed row's level at the pixel's u, (N, pixels, 11)
        by_u = (sv * (by_place[..., 0, :] @ across)).sum(-1)
        by_v = (by_place[..., 1, :] * rows).sum(-1)
        # u = 9 s' with s' = ((I + D) q)_0 / ((I + D) q)_2 and q = (s, t, 1); v likewise
        s, t = self._s, self._t
        q = np.stack([s, t, np.ones_like(s)], axis=-1)
        radial = s * by_u + t * by_v
        jac = np.concatenate(
            [
                GRID * q * by_u[..., None],
                GRID * q * by_v[..., None],
                -GRID * q[..., :2] * radial[..., None],
                (
                    (sv * (by_blur[..., 0, :] @ across)).sum(-1)
                    + (by_blur[..., 1, :] * rows).sum(-1)
                )[..., None],
                (sv * rows).sum(-1)[..., None],
            ],
            axis=-1,
        )
        return self._unlit(jac * self._weight[..., None])

    def refine(self, nibbles: np.ndarray, steps: int) -> None:
        """Move the corners and the blur width ``steps`` Gauss-Newton steps towards the best
        fit of the prints of ``nibbles (N, 7)`` (the contrast is fitted at every step)."""
        for _ in range(steps):
            jac = self._jacobian(nibbles)
            predicted = jac[..., 9]
            contrast = (predicted * self._levels).sum(1) / np.maximum((predicted**2).sum(1), 1e-12)
            residual = self._levels - contrast[:, None] * predicted
            jac[..., :9] *= contrast[:, None, None]
            normal = jac.transpose(0, 2, 1) @ jac
            # a little Levenberg-Marquardt damping keeps a flat direction from running away
            damping = 1e-3 * np.diagonal(normal, axis1=1, axis2=2) + 1e-12
            normal += damping[:, None, :] * np.eye(10)
            step = np.linalg.solve(normal, jac.transpose(0, 2, 1) @ residual[..., None])[..., 0]
            self._move(step)

    def _move(self, step: np.ndarray) -> None:
        """Take a Gauss-Newton ``step (N, 10)`` (:meth:`_jacobian`'s order, the contrast last,
        unused), shortened so that no entry of ``D`` moves a point by more than about half a
        cell: a far jump is a fit gone astray, and the next step starts from nearer."""
        reach = np.abs(step[:, :8]).max(axis=1) * GRID
        step = step * np.minimum(1.0, 0.5 / np.maximum(reach, 1e-12))[:, None]
        change = np.zeros((len(step), 3, 3))
        change[:, :2, :] = step[:, :6].reshape(-1, 2, 3)
        change[:, 2, :2] = step[:, 6:8]
        self._inverse = (np.eye(3) + change) @ self._inverse
        self._log_blur = np.clip(self._log_blur + step[:, 8], np.log(0.3), np.log(2.5))

    def read_rows(self, nibbles: np.ndarray) -> tuple[np.ndarray, ...]:
        """:func:`_row_search` from ``nibbles (N, 7)`` on the pixels as the quads now lie,
        and how unevenly the reading's misfit lies over the marker (:meth:`_unevenness`)."""
        spread = self._spreads()[0]
        su, sv = spread[..., 0, :], spread[..., 1, :]
        rest = _printed_grids(np.zeros_like(nibbles))
        rest[:, 2:-2, 2:-2] = 0.0  # border and quiet zone only
        pixels = su.shape[:-1]
        cells = np.empty(pixels + (_DATA + 1,))
        cells[..., :_DATA] = (sv[..., 2:-2, None] * su[..., None, 2:-2]).reshape(*pixels, _DATA)
        cells[..., _DATA] = (sv * (su @ rest.transpose(0, 2, 1))).sum(-1)
        cells = self._unlit(cells * self._weight[..., None])
        g = (self._levels[:, None, :] @ cells)[:, 0]
        gram = cells.transpose(0, 2, 1) @ cells
        read, top, second = _row_search(g, gram, _own_terms(gram), nibbles, 2)
        whites = np.concatenate(
            [_WORDS[read].reshape(len(read), _DATA), np.ones((len(read), 1))], 1
        )
        return read, top, second, self._unevenness((cells @ whites[..., None])[..., 0])

    def _unevenness(self, predicted: np.ndarray) -> np.ndarray:
        """``(N,)``: the largest share of the misfit of the unlit ``predicted (N, pixels)`` in
        one of the marker's nine blocks of 3x3 cells (the pixels beyond the border in the
        block nearest), over that block's share of the pixels: 1.4 (1.8 at most in nine of
        ten) for a marker whose misfit is noise; a shape partly covering a marker leaves
        it under the shape, and there a wrong reading fits as well as the right one would."""
        contrast = (predicted * self._levels).sum(1) / np.maximum((predicted**2).sum(1), 1e-12)
        misfit = (self._levels - contrast[:, None] * predicted) ** 2
        column = np.clip(self._s * 3.0, 0, 2).astype(int)
        row = np.clip(self._t * 3.0, 0, 2).astype(int)
        blocks = np.zeros((len(predicted), 9))
        counts = np.zeros((len(predicted), 9))
        candidate = np.arange(len(predicted))[:, None]
        np.add.at(blocks, (candidate, 3 * row + column), misfit * self._weight)
        np.add.at(counts, (candidate, 3 * row + column), self._weight)
        share = blocks / np.maximum(blocks.sum(1, keepdims=True), 1e-12)
        return (share / np.maximum(counts / counts.sum(1, keepdims=True), 1e-12)).max(axis=1)

    def read(self, nibbles: np.ndarray) -> tuple[np.ndarray, ...]:
        """The refined reading from a first reading's ``nibbles (N, 7)``: nibbles, their
        correlation and the nearest other reading's (:func:`_row_search`), and how unevenly
        its misfit lies (:meth:`_unevenness`)."""
        self.refine(nibbles, REFINE_STEPS[0])
        read = self.read_rows(nibbles)
        if (read[0] != nibbles).any():  # fit the corners to the new rows, then read them again
            self.refine(read[0], REFINE_STEPS[1])
            read = self.read_rows(read[0])
        return read

    def corners(self) -> np.ndarray:
        """The quads' corners ``(N, 4, 2)`` (px) as the fit now has them."""
        mapped = np.einsum("nij,kj->nki", np.linalg.inv(self._inverse), _CORNERS)
        return mapped[..., :2] / mapped[..., 2:] + self._centre[:, None]


@functools.lru_cache(maxsize=1)
def hamming_blur_reader() -> HammingBlurReader:
    """The reader, built once a process (its tables are the same for every tracker)."""
    return HammingBlurReader()


__all__ = ["BLUR_CELLS", "MIN_FIT", "MIN_GAP", "HammingBlurReader", "hamming_blur_reader"]
