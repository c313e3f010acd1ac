"""The ``hamming`` tracker: Hampy-format markers (seed 004), our own detector.

Pipeline per frame: grey, the profile's preprocessing (seed 004: threshold at
40 % of full scale, slight blur), outer contours of dark regions that are
convex quadrilaterals, the 9x9 cells read through each quad's homography (all
candidates in one ``cv2.remap``), each cell compared with the midpoint of
the black border and the white quiet zone around it (planes fitted over the
marker, so a marker half in shadow reads like one in full light), then
Hamming(7,4) decoding of the four rotations at once. Corners are refined to sub-pixel
accuracy from the square's edges (:mod:`.refine`) before the cells are read.

Unlike Hampy, which reports every rotation that decodes, a marker here gets
exactly one id and one orientation: a rotation that reads as an id registered
in the profile wins, then the rotation needing the fewest bit corrections,
and a tie that remains is reported once with ``ambiguous=True`` (smallest id
first). The format needs this: small ids read upside down are other valid
ids (id 2 turned 180 degrees is exactly id 2 << 24, id 1 is one bit from
3 << 24), so profiles should register the ids they use.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from armtree.params import Param
from armtree.rig import Detection, Frame, RigContext, Tracker

from .common import TagRoles, check_config, finish_detection
from .hamming_code import BITS, GRID, MAX_ID, ROW_WEIGHTS, decode_words
from .preprocess import Preprocessing, threshold_image, to_gray
from .refine import refine_corners, remap_points

FAMILY = "hamming"
#: Seed 004's preprocessing: threshold at 40 % of full scale, slight Gaussian blur.
SEED_PREPROCESS = {"threshold": 0.4, "blur": 3}

# Sample offsets inside a cell (in cells): the centre and four points around it.
_OFFSETS = np.array([[0.5, 0.5], [0.35, 0.35], [0.65, 0.35], [0.65, 0.65], [0.35, 0.65]])
_CELL_CENTRES = (
    np.stack(np.meshgrid(np.arange(GRID), np.arange(GRID)), axis=-1).reshape(-1, 2) + 0.5
)
_CELL_UV = (_CELL_CENTRES[:, None, :] - 0.5 + _OFFSETS).reshape(-1, 2)
# The quiet zone just outside the border, 0.6 of a cell out, along all four sides.
_ALONG = np.arange(GRID) + 0.5
_QUIET_UV = np.concatenate(
    [
        np.column_stack([_ALONG, np.full(GRID, -0.6)]),
        np.column_stack([np.full(GRID, GRID + 0.6), _ALONG]),
        np.column_stack([_ALONG, np.full(GRID, GRID + 0.6)]),
        np.column_stack([np.full(GRID, -0.6), _ALONG]),
    ]
)
_BORDER = np.ones((GRID, GRID), dtype=bool)
_BORDER[1:-1, 1:-1] = False
_BORDER_FLAT = _BORDER.ravel()


def _plane_fit(uv: np.ndarray) -> np.ndarray:
    """Least-squares operator: samples at ``uv`` -> coefficients of a + b u + c v."""
    design = np.column_stack([np.ones(len(uv)), uv])
    return np.linalg.pinv(design)


# Light falls unevenly across a marker (a shadow edge, a lamp to one side), so the
# black and white references are planes over the marker, fitted to the border
# cells (black by the format) and to the quiet zone around it (white).
_BLACK_FIT = _plane_fit(_CELL_CENTRES[_BORDER_FLAT])
_WHITE_FIT = _plane_fit(_QUIET_UV)
_CELL_DESIGN = np.column_stack([np.ones(GRID * GRID), _CELL_CENTRES])
#: How far a cell is pushed away from its neighbours' mean before thresholding. 1.5
#: rather than 1: on the benchmark's noisy, blurred frames it reads 20 px markers
#: 240/240 (adaptive threshold) instead of 237/240 and 16-18 px ones far more often,
#: and it removed the false ids that 1 gave there; 2 gave a false id at 60 px.
_SHARPEN = 1.5
#: Every point read per candidate, as fractions of the marker side: cell samples, then quiet zone.
_SAMPLE_UV = np.concatenate([_CELL_UV, _QUIET_UV]) / GRID
#: Corner order of a quad whose printed top-left corner is its corner k.
_ROLLS = np.array([[(k + i) % 4 for i in range(4)] for k in range(4)])
_NO_KEY = 1 << 20
_NEXT = np.array([1, 2, 3, 0])
_UNIT_SQUARE = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32)
# Index in the 81 cells of each data cell after turning the inner 7x7 grid k
# quarter turns (np.rot90's sense): (4, 7, 7).
_INNER = np.arange(GRID * GRID).reshape(GRID, GRID)[1:-1, 1:-1]
_INNER_FLAT = _INNER.ravel()
_ROTATED_INNER = np.stack([np.rot90(_INNER, k) for k in range(4)])
_COLUMNS = np.arange(BITS)


def square_to_quad(quads: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Image points ``(N, P)`` x and y of unit-square points ``uv (P, 2)`` in quads ``(N, 4, 2)``.

    The projective map of (0,0), (1,0), (1,1), (0,1) onto each quad's corners
    (OpenCV's ``getPerspectiveTransform``, one small call per quad), applied
    to all points of all quads in one matrix product.
    """
    quads = np.asarray(quads, dtype=np.float32)
    maps = np.stack([cv2.getPerspectiveTransform(_UNIT_SQUARE, q) for q in quads])
    points = maps @ np.vstack([np.asarray(uv, dtype=np.float64).T, np.ones(len(uv))])
    w = points[:, 2]
    w = np.where(np.abs(w) < 1e-12, 1e-12, w)  # a degenerate quad reads as nothing, not a crash
    return points[:, 0] / w, points[:, 1] / w


def _samples(gray: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Grey levels ``(N, P)`` at every quad's ``_SAMPLE_UV`` points: cell samples, then quiet zone."""
    map_x, map_y = square_to_quad(quads, _SAMPLE_UV)
    values = remap_points(gray, np.stack([map_x.ravel(), map_y.ravel()], axis=1))
    return values.reshape(len(quads), -1)


def _linear_reading(cells: np.ndarray, quiet: np.ndarray) -> np.ndarray:
    """The linear part of :meth:`HammingTracker.classify`, ``(N, 3 * 81 + 1)``.

    Each cell sharpened against its four neighbours, the threshold plane
    under it (the midpoint of the black and white planes), the black-white
    difference there, and the marker's contrast at its centre.
    """
    n = len(cells)
    padded = np.empty((n, GRID + 2, GRID + 2))
    padded[:, 1:-1, 1:-1] = cells.reshape(n, GRID, GRID)
    padded[:, 0, 1:-1] = quiet[:, 0:GRID]
    padded[:, 1:-1, -1] = quiet[:, GRID : 2 * GRID]
    padded[:, -1, 1:-1] = quiet[:, 2 * GRID : 3 * GRID]
    padded[:, 1:-1, 0] = quiet[:, 3 * GRID :]
    neighbours = 0.25 * (
        padded[:, :-2, 1:-1] + padded[:, 2:, 1:-1] + padded[:, 1:-1, :-2] + padded[:, 1:-1, 2:]
    )
    sharp = cells + _SHARPEN * (cells - neighbours.reshape(n, -1))
    black = cells[:, _BORDER_FLAT] @ _BLACK_FIT.T  # (N, 3)
    white = quiet @ _WHITE_FIT.T
    threshold = 0.5 * (black + white) @ _CELL_DESIGN.T  # (N, 81)
    difference = (white - black) @ _CELL_DESIGN.T
    contrast = (white - black) @ np.array([1.0, GRID / 2, GRID / 2])
    return np.concatenate([sharp, threshold, difference, contrast[:, None]], axis=1)


def _split_reading(linear: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """White cells, margins and contrast from :func:`_linear_reading`'s output."""
    k = GRID * GRID
    sharp, threshold = linear[:, :k], linear[:, k : 2 * k]
    local = np.maximum(linear[:, 2 * k : 3 * k], 1.0)
    return sharp > threshold, (sharp - threshold) / local, linear[:, 3 * k]


# classify() is linear up to its last step: one matrix, built by applying it to unit vectors.
_N_READ = GRID * GRID + len(_QUIET_UV)
_CLASSIFY_OP = _linear_reading(np.eye(_N_READ)[:, : GRID * GRID], np.eye(_N_READ)[:, GRID * GRID :])


@dataclass
class _Reading:
    """One decoded candidate: printed-order corners, id, bits corrected, ambiguity."""

    corners: np.ndarray
    marker_id: int
    corrected: int
    ambiguous: bool


class HammingTracker(Tracker):
    """Finds Hampy-format Hamming markers; one detection per physical marker.

    ``max_corrected_bits`` bounds the corrections over the seven rows (each
    row corrects at most one, as Hamming(7,4) allows); a correction that flips
    a clearly read cell while another cell of the row is in doubt (margin
    below ``max_flip_margin``, a fraction of the local black-white difference)
    is refused, as that is how a double error looks; ``max_border_errors``
    how many of the 32 border cells may read white; ``only_registered``
    drops ids the profile does not list.
    """

    family = FAMILY

    def __init__(
        self,
        preprocessing: Preprocessing | None = None,
        roles: TagRoles | None = None,
        *,
        min_side_px: float = 12.0,
        max_corrected_bits: int = 2,
        max_border_errors: int = 1,
        min_contrast: float = 20.0,
        only_registered: bool = False,
        refine: bool = True,
        max_flip_margin: float = 0.25,
    ) -> None:
        self.preprocessing = preprocessing or Preprocessing(**SEED_PREPROCESS)
        self.roles = roles or TagRoles({})
        self.min_side_px = float(min_side_px)
        self.max_corrected_bits = int(max_corrected_bits)
        self.max_border_errors = int(max_border_errors)
        self.min_contrast = float(min_contrast)
        self.only_registered = bool(only_registered)
        self.refine = bool(refine)
        self.max_flip_margin = float(max_flip_margin)

    # -- the Tracker contract -------------------------------------------------

    def detect(self, frame: Frame) -> list[Detection]:
        """Every Hamming marker in ``frame``; poses when its size and intrinsics are known."""
        gray = to_gray(frame.image)
        quads = self.candidates(gray)
        if self.refine and len(quads):
            # refined corners put the cell samples on the cells, which matters at 2-3 px per cell
            quads = refine_corners(gray, quads, GRID, contour_inset=0.5)
        readings = self.decode(gray, quads)
        detections = []
        for r in readings:
            det = Detection(
                id=r.marker_id,
                corners=r.corners,
                family=FAMILY,
                quality=float(r.corrected),
                ambiguous=r.ambiguous,
            )
            detections.append(finish_detection(det, self.roles, frame, pose_quality=False))
        return detections

    # -- stages (public so benchmarks and tests can look inside) ----------------

    def candidates(self, gray: np.ndarray) -> np.ndarray:
        """Convex dark quadrilaterals ``(N, 4, 2)`` float32, clockwise on screen."""
        if self.preprocessing.binarises:
            dark = self.preprocessing.dark(gray)
        else:
            processed = self.preprocessing.apply(gray)
            dark = threshold_image(processed, 0, cv2.THRESH_BINARY_INV | cv2.THRESH_OTSU)
        # findContoursLinkRuns gives what RETR_CCOMP with CHAIN_APPROX_SIMPLE gives,
        # without findContours' internal full-frame threshold, which OpenCV runs on
        # its worker threads and which cost twice the contour search in CPU time.
        contours, _ = cv2.findContoursLinkRuns(dark)
        min_perimeter = 4.0 * self.min_side_px
        h, w = gray.shape
        max_perimeter = 2.0 * (w + h)
        min_area = 0.5 * self.min_side_px**2
        found = []
        for contour in contours:
            # outer edges of dark regions run one way, holes (inner edges of dark rings)
            # the other; the hierarchy link runs return does not say which is which
            area = cv2.contourArea(contour, True)
            if area < min_area or len(contour) < 4:
                continue
            perimeter = cv2.arcLength(contour, True)
            if perimeter < min_perimeter or perimeter > max_perimeter:
                continue
            approx = cv2.approxPolyDP(contour, 0.03 * perimeter, True)
            if len(approx) != 4 or not cv2.isContourConvex(approx):
                continue
            # a square's outline fills its quad; a blob's (an ellipse, a hand) does not
            fill = area / max(cv2.contourArea(approx), 1.0)
            if 0.8 < fill < 1.2:
                found.append(approx)
        if not found:
            return np.zeros((0, 4, 2), np.float32)
        quads = np.concatenate(found).reshape(-1, 4, 2).astype(np.float32)
        edges = quads[:, _NEXT] - quads
        quads = quads[np.hypot(edges[..., 0], edges[..., 1]).min(axis=1) >= self.min_side_px]
        # clockwise on screen (y down): positive shoelace sum
        x, y = quads[..., 0], quads[..., 1]
        area2 = (x * y[:, _NEXT] - x[:, _NEXT] * y).sum(axis=1)
        quads[area2 < 0] = quads[area2 < 0][:, ::-1]
        return quads

    def sample_cells(self, gray: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Grey levels of every quad's 81 cells ``(N, 81)`` and of its quiet zone ``(N, 36)``.

        The cells are read in the quad's corner order: row 0 runs from
        ``quad[0]`` to ``quad[1]``, column 0 from ``quad[0]`` to ``quad[3]``.
        """
        values = _samples(gray, quads)
        n_cells = len(_CELL_UV)
        cells = values[:, :n_cells].reshape(len(values), GRID * GRID, len(_OFFSETS)).sum(axis=2)
        return cells / len(_OFFSETS), values[:, n_cells:]

    def classify(
        self, cells: np.ndarray, quiet: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """White cells ``(N, 81)``, their margins ``(N, 81)`` and the contrast ``(N,)`` of every quad.

        Blur bleeds neighbouring cells into each other (a lone white cell of 2 px
        under 1 px of blur keeps about half its contrast), so each cell is first
        pushed away from the mean of its four neighbours (the quiet zone beyond
        the border), then compared with the midpoint of the black plane (fitted
        to the border cells) and the white plane (fitted to the quiet zone).
        A margin is the distance from that midpoint as a fraction of the local
        black-white difference: about 0.5 for a clear cell, near 0 for a doubtful one.
        """
        return _split_reading(np.concatenate([cells, quiet], axis=1) @ _CLASSIFY_OP)

    def decode(self, gray: np.ndarray, quads: np.ndarray) -> list[_Reading]:
        """Read, check and decode every candidate; one reading per accepted marker."""
        if len(quads) == 0:
            return []
        white, margin, contrast = self.classify(*self.sample_cells(gray, quads))
        border_white = white[:, _BORDER_FLAT].sum(axis=1)
        inner = white[:, _INNER_FLAT].sum(axis=1)
        # Hampy rejects all-black and all-white insides; so do we.
        keep = (
            (contrast >= self.min_contrast)
            & (border_white <= self.max_border_errors)
            & (inner > 0)
            & (inner < BITS * BITS)
        )
        if not keep.any():
            return []
        quads = quads[keep]
        # rotated[:, k] is the marker as printed when its top-left corner is quads[k]
        # (np.rot90(grid, k) of the inner 7x7 cells), row by row.
        rotated = white[keep][:, _ROTATED_INNER]  # (M, 4, 7, 7)
        rotated_margins = np.abs(margin[keep])[:, _ROTATED_INNER]
        ids, corrected, flips = decode_words(rotated @ ROW_WEIGHTS)  # (M, 4), (M, 4), (M, 4, 7)
        # A row with two misread (doubtful) cells decodes to a wrong nibble by flipping
        # a third, clearly read, cell: a correction that flips a clear cell while
        # another cell of its row is in doubt is refused. A clear single error (a
        # damaged print) is still corrected.
        flipped = (rotated_margins * (flips[..., None] == _COLUMNS)).sum(axis=-1)
        doubt_elsewhere = rotated_margins.min(axis=-1) < self.max_flip_margin
        refused = (flips >= 0) & (flipped > self.max_flip_margin) & doubt_elsewhere
        # Ids 0 and 2**28 - 1 are an all-black and an all-white inside, which Hampy never reads.
        rejected = refused.any(axis=-1) | (ids == 0) | (ids == MAX_ID - 1)
        corrected = np.where(rejected, BITS + 1, corrected)
        return self._choose(quads, ids, corrected)

    def _choose(self, quads: np.ndarray, ids: np.ndarray, corrected: np.ndarray) -> list[_Reading]:
        """One reading per marker: registered ids first, then fewest corrections, then smallest id."""
        table = self.roles.table
        valid = corrected <= self.max_corrected_bits
        if table:
            registered = np.isin(ids, np.fromiter(table, dtype=np.int64, count=len(table)))
            if self.only_registered:
                valid &= registered
            key = np.where(valid, (~registered) * (BITS + 2) + corrected, _NO_KEY)  # (M, 4)
        elif self.only_registered:
            return []
        else:
            key = np.where(valid, BITS + 2 + corrected, _NO_KEY)
        best = key.min(axis=1)
        rows = np.flatnonzero(best < _NO_KEY)
        if len(rows) == 0:
            return []
        key, ids, corrected, best = key[rows], ids[rows], corrected[rows], best[rows]
        is_best = key == best[:, None]
        ties = is_best.sum(axis=1)
        k = np.where(is_best, ids, np.iinfo(np.int64).max).argmin(axis=1)
        corners = quads[rows[:, None], _ROLLS[k]]
        chosen_corrections = corrected[np.arange(len(rows)), k]
        kept = _dedupe(corners, chosen_corrections, ties > 1)
        corners = corners[kept]
        chosen = (np.arange(len(rows))[kept], k[kept])
        return [
            _Reading(c, int(i), int(n), bool(t > 1))
            for c, i, n, t in zip(corners, ids[chosen], corrected[chosen], ties[kept], strict=True)
        ]


def _dedupe(corners: np.ndarray, corrected: np.ndarray, ambiguous: np.ndarray) -> np.ndarray:
    """Indices (ascending) of the readings of quads ``(N, 4, 2)`` to keep.

    Of two whose centres are within half a side of each other, the better
    reading wins: fewer bits corrected, then not ambiguous, then the larger.
    A dark sheet with a white window around a marker can itself read as a
    marker with corrections; the marker in the window, read cleanly, is the one.
    """
    if len(corners) < 2:
        return np.arange(len(corners))
    x, y = corners[..., 0], corners[..., 1]
    area = 0.5 * np.abs((x * y[:, _NEXT] - x[:, _NEXT] * y).sum(axis=1))
    centres = 0.25 * corners.sum(axis=1)
    gap2 = ((centres[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2)
    close = gap2 <= area.max() / 4.0
    np.fill_diagonal(close, False)
    if not close.any():
        return np.arange(len(corners))
    kept: list[int] = []
    for i in np.lexsort((-area, ambiguous, corrected)):
        if not np.any(gap2[i, kept] <= np.maximum(area[i], area[kept]) / 4.0):
            kept.append(int(i))
    return np.array(sorted(kept), dtype=np.intp)


def hamming_factory(config: dict[str, Any], context: RigContext) -> HammingTracker:
    """Hampy-format Hamming markers (9x9, 28-bit ids), seed 004's preprocessing by default."""
    where = context.profile
    values = check_config(config, hamming_factory.PARAMS, "tracker", where)
    roles = TagRoles.from_profile(context.profile, values["size_mm"])
    return HammingTracker(
        Preprocessing.from_config(values["preprocess"], where),
        roles,
        min_side_px=values["min_side_px"],
        max_corrected_bits=values["max_corrected_bits"],
        max_border_errors=values["max_border_errors"],
        min_contrast=values["min_contrast"],
        only_registered=values["only_registered"],
        refine=values["refine"],
        max_flip_margin=values["max_flip_margin"],
    )


hamming_factory.PARAMS = (
    Param("preprocess", "dict", SEED_PREPROCESS, doc="threshold, adaptive, block_px, offset, blur"),
    Param("size_mm", "float", None, unit="mm", doc="side of markers not listed in tags:"),
    Param("min_side_px", "float", 12.0, unit="px", doc="smallest marker side looked for"),
    Param("max_corrected_bits", "int", 2, doc="bit corrections allowed per marker, one per row"),
    Param("max_border_errors", "int", 1, doc="border cells allowed to read white"),
    Param("min_contrast", "float", 20.0, doc="grey levels between a marker's black and white"),
    Param("only_registered", "bool", False, doc="report only ids listed in the profile's tags:"),
    Param("refine", "bool", True, doc="sub-pixel corners from the square's edges"),
    Param(
        "max_flip_margin",
        "float",
        0.25,
        doc="cells read closer than this to the threshold are in doubt",
    ),
)
