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
word changes the fit's correlation in closed form. Starting from a grey inside,
every row in turn takes the word of its 16 that fits best, for each of the four
turns and a few blur widths, until no row changes.

Each candidate is read at a few insets of its sides (:data:`INSETS_PX`), the best
fit kept. A reading is kept only when it fits well (:data:`MIN_FIT`) and much
better than the nearest other reading, the best fit with one row's word changed,
under another turn or of another id at another inset (:data:`MIN_GAP`, the ratio
of unexplained variances), and when its id is a valid marker (:func:`.hamming_code.id_problem`). Two code words of a row
differ in at least three cells, so that second reading is the one a wrong id
would have to beat.
"""

from __future__ import annotations

import functools

import numpy as np

from .blur_decode import cell_spread, clear_readings, light_basis, sample_grid
from .hamming_code import BITS, CODEWORDS, GRID, REFUSED_IDS, id_problem
from .kernels import sample_cells

#: Least correlation between a candidate's levels and its reading's prediction.
MIN_FIT = 0.97
#: Least ratio of the unexplained variance of the nearest other reading to the best's.
MIN_GAP = 1.6
#: Blur widths tried (sd, in cells): from a sharp print to a pixel of blur at 1.8 px a cell.
BLUR_CELLS = (0.3, 0.5, 0.7)
#: Sweeps over the seven rows at most (the fit seldom changes after the second).
SWEEPS = 3
#: How far in (px) the fit reads each side of a candidate, each tried, the best fit
#: kept: the candidate search's corners sit up to a few tenths of a pixel outside a
#: blurred marker's border (0.13 px on average at 16-20 px), which at 16 px misplaces
#: the outer cells by a tenth of a cell, but not always.
INSETS_PX = (0.0, 0.15, 0.3)

_PRINTED = GRID + 2  # the marker and a ring of quiet zone around it
_WORDS = CODEWORDS.astype(np.float64)  # (16, 7)
_SHIFTS = 4 * np.arange(BITS - 1, -1, -1)


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
        self._base, self._data, self._base2, self._cross, self._gram = [], [], [], [], []
        for sd in BLUR_CELLS:
            spread = cell_spread(x, GRID, sd)
            predict = unlight @ np.kron(spread, spread)  # (points, printed cells), unlit
            base = predict @ fixed.ravel()
            self._base.append(base)
            self._base2.append(float(base @ base))
            data = np.stack([predict[:, t] for t in turned])  # (4, points, 49)
            self._data.append(data)
            self._cross.append(np.einsum("kpc,p->kc", data, base))  # (4, 49)
            self._gram.append(np.einsum("kpc,kpd->kcd", data, data))  # (4, 49, 49)
        self._base_a = np.stack(self._base)  # (S, points)
        self._data_a = np.stack(self._data)  # (S, 4, points, 49)
        self._base2_a = np.array(self._base2)  # (S,)
        self._cross_a = np.stack(self._cross)  # (S, 4, 49)
        self._gram_a = np.stack(self._gram)  # (S, 4, 49, 49)
        # each code word's own term of the squared norm, in each row: (S, 4, 7, 16)
        self._own = np.stack(
            [
                np.einsum("jc,skcd,jd->skj", _WORDS, self._gram_a[:, :, rows, rows], _WORDS)
                for rows in (slice(BITS * r, BITS * (r + 1)) for r in range(BITS))
            ],
            axis=2,
        )

    def levels(self, gray: np.ndarray, quads: np.ndarray, inset_px: float = 0.0) -> np.ndarray:
        """Each quad's grey levels at the fit's points, each side moved ``inset_px`` in,
        light removed, of unit length."""
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
        """The best reading of each candidate's ``levels (N, points)``: its rows' nibbles
        ``(N, 7)``, turn ``(N,)``, correlation ``(N,)``, and the correlation of the
        nearest other reading, as ``(nibbles, turns, scores, seconds)`` stacked in the
        last array ``(N, 2)``."""
        n = len(levels)
        s, k = len(BLUR_CELLS), 4
        # one problem per (candidate, blur width, turn); the inside starts grey
        g = np.einsum("skpc,np->nskc", self._data_a, levels)  # (n, s, k, 49)
        x = np.full((n, s, k, BITS * BITS), 0.5)
        gram, cross = self._gram_a[None], self._cross_a[None]
        gx = (gram @ x[..., None])[..., 0]  # the gram matrix times x, kept up to date
        n0 = np.einsum("sp,np->ns", self._base_a, levels)[:, :, None]  # (n, s, 1)
        words = np.full((n, s, k, BITS), -1)
        scores = np.zeros((n, s, k, BITS, 16))
        for _ in range(SWEEPS):
            changed = False
            for r in range(BITS):
                rows = slice(BITS * r, BITS * (r + 1))
                # the fit with row r emptied: its correlation's numerator and squared norm
                old = x[..., rows]
                gy = gx - (gram[..., rows] @ old[..., None])[..., 0]
                y = x.copy()
                y[..., rows] = 0.0
                num = n0 + (g * y).sum(-1)
                quad = self._base2_a[None, :, None] + ((2 * cross + gy) * y).sum(-1)
                # ... and with each of the 16 code words in row r
                num = num[..., None] + g[..., rows] @ _WORDS.T
                den = quad[..., None] + (2 * (cross[..., rows] + gy[..., rows])) @ _WORDS.T
                den += self._own[None, :, :, r]
                score = num / np.sqrt(np.maximum(den, 1e-12))
                best = score.argmax(axis=-1)
                scores[..., r, :] = score
                changed |= bool((best != words[..., r]).any())
                words[..., r] = best
                x[..., rows] = _WORDS[best]
                gx = gy + (gram[..., rows] @ x[..., rows, None])[..., 0]
            if not changed:
                break
        flat_scores = scores.reshape(n * s * k, BITS, 16)
        flat_words = words.reshape(n * s * k, BITS)
        top = flat_scores[:, BITS - 1].max(axis=1)  # the last row saw every other final
        # the nearest other reading of the same turn: one row at its second-best word
        second_row = np.sort(flat_scores, axis=2)[:, :, -2].max(axis=1)
        top = top.reshape(n, s * k)
        best = top.argmax(axis=1)
        turn_of = np.tile(np.arange(k), s)
        best_turn = turn_of[best]
        score = top[np.arange(n), best]
        # the best reading under any other turn
        other_turn = np.where(turn_of[None, :] != best_turn[:, None], top, -np.inf).max(axis=1)
        second = np.maximum(second_row.reshape(n, s * k)[np.arange(n), best], other_turn)
        nibbles = flat_words.reshape(n, s * k, BITS)[np.arange(n), best]
        return nibbles, best_turn, np.column_stack([score, second])

    def read(self, gray: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each quad's id and turn ``(N,)``, ``-1`` where no reading fits as this module asks."""
        count = len(quads)
        ids, turns = np.full(count, -1), np.full(count, -1)
        if count == 0:
            return ids, turns
        # every inset of every quad in one fit, then each quad's best; a reading of
        # another id or turn at another inset is a rival the best must beat too
        tries = len(INSETS_PX)
        levels = np.concatenate([self.levels(gray, quads, inset) for inset in INSETS_PX])
        nibbles, turn, scores = self.fit(levels)
        nibbles = nibbles.reshape(tries, count, BITS)
        turn, top = turn.reshape(tries, count), scores[:, 0].reshape(tries, count)
        own_second = scores[:, 1].reshape(tries, count)
        best = top.argmax(axis=0)
        cols = np.arange(count)
        same = (nibbles == nibbles[best, cols][None]).all(axis=2) & (turn == turn[best, cols][None])
        rival = np.where(same, -np.inf, top).max(axis=0)
        second = np.maximum(own_second[best, cols], rival)
        nibbles, turn, top = nibbles[best, cols], turn[best, cols], top[best, cols]
        ok = clear_readings(top, second, MIN_FIT, MIN_GAP)
        for i in np.flatnonzero(ok):
            marker_id = int((nibbles[i] << _SHIFTS).sum())
            if marker_id in REFUSED_IDS or id_problem(marker_id) is not None:
                continue
            ids[i], turns[i] = marker_id, int(turn[i])
        return ids, turns


@functools.lru_cache(maxsize=1)
def hamming_blur_reader() -> HammingBlurReader:
    """The reader, built once a process (its tables are the same for every tracker)."""
    return HammingBlurReader()


__all__ = ["BLUR_CELLS", "MIN_FIT", "MIN_GAP", "HammingBlurReader", "hamming_blur_reader"]
