"""Reading a small, blurred marker by fitting every word of its dictionary, blurred, to it.

At two pixels a cell (an AprilTag 36h11 of 16 px, a 4x4 marker of 12 px) a
defocus blur of one pixel spreads each cell over its neighbours: a lone white
cell among black ones reads darker than a black cell among white ones, and no
threshold, OpenCV's or :mod:`.rescue`'s, reads the cells one by one. What is
still there is the whole pattern, blurred. This reader predicts, for every
word of the dictionary under each of its four turns and for a few blur widths,
the grey levels a print of it would give at points spread over the marker
(black border, white quiet zone around it, Gaussian blur; a separable sum of
normal CDF differences over each cell's box), and keeps the word whose
prediction fits the candidate's levels best after an unknown black level,
contrast and linear light gradient are fitted away. That is a correlation,
so every candidate of a frame is scored against every word in one matrix
product.

A reading is kept only when it fits well (:data:`MIN_FIT`) and fits much
better than the best word of another id or turn (:data:`MIN_GAP`: the ratio
of their unexplained variances). Dictionaries are built with many bits
between any two words under any turn (AprilTag 36h11: 11), so the wrong word
explains a clean reading badly; over 10,000 benchmark frames no reading that
passed was of a wrong id (docs/benchmarks.md, "Small markers").
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.special import ndtr

from .kernels import sample_cells

#: Least correlation between a candidate's levels and its best word's prediction.
MIN_FIT = 0.9
#: Least ratio of the unexplained variance of the best other word to the best word's.
MIN_GAP = 2.0
#: Blur widths tried (sd, in cells): from a sharp print to one pixel of blur at two
#: pixels a cell, with the sampling's own blur.
BLUR_CELLS = (0.2, 0.3, 0.4, 0.5, 0.6, 0.75)
#: Points read along each side of a cell.
PER_CELL = 2
#: Words scored at every blur width, of those that fit best at the middle one.
SHORTLIST = 32
_MIDDLE = 2


def sample_grid(cells: int) -> tuple[np.ndarray, np.ndarray]:
    """Where a fit reads a marker of ``cells`` a side (border included): the points'
    positions along a side, in cells ``(cells * PER_CELL,)``, and the points on the
    unit square ``(points, 1, 2)`` as :func:`.kernels.sample_cells` takes them, at the
    middle of each of ``PER_CELL**2`` sub-cells, row by row."""
    x = (np.arange(cells * PER_CELL) + 0.5) / PER_CELL
    u, v = np.meshgrid(x / cells, x / cells, indexing="xy")
    return x, np.column_stack([u.ravel(), v.ravel()])[:, None, :]


def light_basis(uv: np.ndarray) -> np.ndarray:
    """``(points, 3)``: what a level may carry apart from the print at points ``uv``
    (:func:`sample_grid`): a black level and a linear light gradient."""
    return np.column_stack([np.ones(len(uv)), uv[:, 0, :] - 0.5])


def cell_spread(x: np.ndarray, cells: int, sd: float) -> np.ndarray:
    """``(len(x), cells + 2)``: how much of each printed cell a Gaussian blur of ``sd``
    cells carries to each point ``x`` along a side (:func:`sample_grid`).

    Printed cell j spans [j - 1, j] cells from the border's outer edge; cells 0 and
    ``cells + 1`` are the quiet zone, reaching out for ever. The blur is separable, so
    the spread of a print is this along rows, then along columns.
    """
    lows = np.concatenate([[-np.inf], np.arange(cells + 1.0)])
    highs = np.concatenate([np.arange(cells + 1.0), [np.inf]])
    return ndtr((x[:, None] - lows) / sd) - ndtr((x[:, None] - highs) / sd)


def clear_readings(
    top: np.ndarray, second: np.ndarray, min_fit: float, min_gap: float
) -> np.ndarray:
    """Which readings to keep: a correlation ``top`` of at least ``min_fit``, and the
    nearest other reading's unexplained variance ``min_gap`` times the best's or more
    (a reading that anti-correlates explains nothing, as one that does not correlate)."""
    top = np.asarray(top, dtype=np.float64)
    second = np.clip(np.asarray(second, dtype=np.float64), 0.0, 1.0)
    unexplained = np.maximum(1.0 - top**2, 1e-12)
    return (top >= min_fit) & ((1.0 - second**2) / unexplained >= min_gap)


class BlurFitReader:
    """Reads candidates of one ArUco-style dictionary by fitting its blurred words.

    ``words`` ``(K, n * n)`` are the dictionary's n x n insides as they read under
    each turn, id by id: row ``4 * id + turn`` (as :class:`.rescue.Rescuer` lists
    them). Markers are these insides in a one-cell black border, printed in a white
    quiet zone.
    """

    def __init__(self, words: np.ndarray) -> None:
        bits = int(round(np.sqrt(words.shape[1])))
        cells = bits + 2
        count = len(words)
        printed = np.ones((count, cells + 2, cells + 2), dtype=np.float32)  # quiet zone
        printed[:, 1:-1, 1:-1] = 0.0  # border, black
        printed[:, 2:-2, 2:-2] = words.reshape(count, bits, bits)
        #: Each word's id and turn (the marker's top-left corner is quad corner ``turn``).
        self.ids, self.turns = np.divmod(np.arange(count), 4)
        self._count = count
        x, self._uv = sample_grid(cells)
        light = light_basis(self._uv)
        self._light = light.astype(np.float32)
        self._unlight = np.linalg.pinv(light).astype(np.float32)
        fits = []
        for sd in BLUR_CELLS:
            spread = cell_spread(x, cells, sd).astype(np.float32)
            # along rows, then along columns, of every word at once
            along_rows = printed.reshape(-1, cells + 2) @ spread.T  # (words x rows, x)
            along_rows = along_rows.reshape(count, cells + 2, -1).transpose(0, 2, 1)
            blurred = (along_rows.reshape(-1, cells + 2) @ spread.T).reshape(count, -1)
            # (words, x * y) as (x, y): transpose to the points' order, y then x
            by_point = blurred.reshape(count, len(x), len(x)).transpose(0, 2, 1)
            predicted = self._unlit(by_point.reshape(count, -1).T).T
            predicted /= np.linalg.norm(predicted, axis=1, keepdims=True)
            fits.append(predicted)
        #: (blur widths, words, points): each word's prediction, unlit and of unit length.
        self._words = np.ascontiguousarray(np.stack(fits), dtype=np.float32)

    def _unlit(self, levels: np.ndarray) -> np.ndarray:
        """``levels (points, K)`` less their best fit of a black level and a linear gradient."""
        return levels - self._light @ (self._unlight @ levels)

    def fits(self, gray: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The words that fit each quad ``(N, 4, 2)`` best: their indices ``(N, SHORTLIST)``
        and correlations (1 a perfect fit; below 0 a word darker where the candidate is
        lighter), best first.

        Every word is scored at one middle blur width; the :data:`SHORTLIST` best are
        scored again at every width. A word far down the list at the middle width fits
        badly at every width, and reading a tenth of the table keeps this cheap.
        """
        levels = sample_cells(gray, np.asarray(quads, np.float64), self._uv, np.zeros((0, 2)))
        levels = self._unlit(levels.T).T
        norm = np.linalg.norm(levels, axis=1, keepdims=True)
        levels = (levels / np.maximum(norm, 1e-9)).astype(np.float32)  # (N, points)
        first = levels @ self._words[_MIDDLE].T  # (N, words)
        k = min(SHORTLIST, self._count)
        shortlist = np.argpartition(-first, k - 1, axis=1)[:, :k]
        # (widths, N, k, points) . (N, points): each shortlisted word at every width
        scores = np.einsum("snkp,np->snk", self._words[:, shortlist], levels).max(axis=0)
        order = np.argsort(-scores, axis=1)
        return np.take_along_axis(shortlist, order, 1), np.take_along_axis(scores, order, 1)

    def read(self, gray: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each quad's id and turn ``(N,)``, ``-1`` where no word fits as this module asks."""
        n = len(quads)
        ids, turns = np.full(n, -1), np.full(n, -1)
        if n == 0:
            return ids, turns
        words, scores = self.fits(gray, quads)
        best = words[:, 0]
        ok = clear_readings(scores[:, 0], scores[:, 1], MIN_FIT, MIN_GAP)
        ids[ok], turns[ok] = self.ids[best[ok]], self.turns[best[ok]]
        return ids, turns


def blur_fit_reader(words: np.ndarray) -> BlurFitReader:
    """The reader of ``words`` (as :class:`BlurFitReader` takes them), built once a process:
    its table of blurred words (22 MB for AprilTag 36h11) is the same for every tracker."""
    words = np.ascontiguousarray(words, dtype=np.uint8)
    return _reader(words.tobytes(), words.shape)


@functools.lru_cache(maxsize=4)
def _reader(words: bytes, shape: tuple[int, int]) -> BlurFitReader:
    return BlurFitReader(np.frombuffer(words, dtype=np.uint8).reshape(shape))


__all__ = [
    "BLUR_CELLS",
    "MIN_FIT",
    "MIN_GAP",
    "BlurFitReader",
    "blur_fit_reader",
    "cell_spread",
    "clear_readings",
    "light_basis",
    "sample_grid",
]
