"""The ``hamming`` tracker: Hampy-format markers (Showers 2016), our own detector.

Pipeline per frame: grey, the profile's preprocessing (Showers 2016: threshold at
40 % of full scale, slight blur), outer contours of dark regions that are
convex quadrilaterals, the 9x9 cells read through each quad's homography
(:mod:`.kernels`, all candidates at once), each cell compared with the midpoint of
the black border and the white quiet zone around it (planes fitted over the
marker, so a marker half in shadow reads like one in full light), then
Hamming(7,4) decoding of the four rotations at once, by soft decision (each
row's code word chosen by how far its disagreeing cells are from the
threshold, :func:`.kernels.read_markers`). Corners are refined to sub-pixel
accuracy from the square's edges (:mod:`.refine`) before the cells are read.

Unlike Hampy, which reports every rotation that decodes, a marker here gets
exactly one id and one orientation: a rotation that reads as an id registered
in the profile wins, then the rotation needing the fewest bit corrections,
and a tie that remains is reported once with ``ambiguous=True`` (smallest id
first). Ids whose turns read as other ids are not valid markers at all
(:func:`.hamming_code.id_problem`; id 2 turned 180 degrees is exactly id
2 << 24): profiles and ``armtree markers`` refuse them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import cv2
import numpy as np

from armtree.api.component_factory import CheckedFactory
from armtree.api.rig import Detection, Frame, RigContext, Tracker
from armtree.config.component_config import check_config
from armtree.config.params import Param
from armtree.loader.profile import Profile

from .common import TagRoles, finish_detection, probe
from .hamming_blur import hamming_blur_reader
from .hamming_code import CODEWORDS, GRID
from .kernels import apart_from, best_of_overlapping, read_markers, sample_cells
from .preprocess import Preprocessing, dark_quads, mostly_dark, threshold_image, to_gray
from .refine import refine_corners

FAMILY = "hamming"
#: How much better (summed cell margins) a row's code word must fit than the next:
#: enough to refuse the guesses that made wrong ids of small tilted markers, not so
#: much that clean rows are refused (docs/benchmarks-history.md, "Small markers").
MIN_ROW_GAP = 1.0
#: Candidates up to this side (px) that the cell reading leaves unread are fitted with
#: blurred code words (:mod:`.hamming_blur`); larger markers have cells to threshold.
BLUR_FIT_MAX_SIDE_PX = 32.0
#: ... and down to this side (the search's default ``min_side_px``): at 1.1-1.3 px a
#: cell a fit is often of the wrong code word, but then of one that barely fits better
#: than the next, which the fit refuses (in 20,000 benchmark frames the wrong readings of
#: candidates under 12 px fitted at most 1.5 times better than the next, against 2.2
#: asked, :data:`.hamming_blur.MIN_GAP`).
BLUR_FIT_MIN_SIDE_PX = 10.0
#: The shortest side (px) whose candidate's cells are read one by one; smaller ones
#: (the search looks down to ``min_side_px``) go to the blur fit alone.
CELLS_MIN_SIDE_PX = 12.0
#: The fine search's local threshold: small markers' borders stand out of a 7 px
#: neighbourhood where a threshold for the whole frame merges them with their cells.
FINE_SEARCH: dict[str, Any] = {"adaptive": True, "block_px": 7, "offset": 7.0}
#: ... then a pixel stays dark when at most this many of 16 around it are light, weighed
#: as a 3x3 Gaussian blur weighs them (:func:`.preprocess.mostly_dark`): a blurred 16 px marker's
#: border thresholds to a ring 1-2 px wide, which Showers 2016's blur (at most 7) breaks
#: where a white cell touches it, while lone dark pixels of noise still go (benchmark
#: frames with noise and blur: 99 % of 16 px and 83 % of 14 px markers outlined, 96 % and
#: 73 % at 7).
FINE_MOST_LIGHT = 9
#: Showers 2016's preprocessing: threshold at 40 % of full scale, slight Gaussian blur.
SEED_PREPROCESS: dict[str, Any] = {"threshold": 0.4, "blur": 3}

# Sample offsets inside a cell (in cells): the centre and four points around it.
_OFFSETS = np.array([[0.5, 0.5], [0.35, 0.35], [0.65, 0.35], [0.65, 0.65], [0.35, 0.65]])
_CELL_CENTRES = (
    np.stack(np.meshgrid(np.arange(GRID), np.arange(GRID)), axis=-1).reshape(-1, 2) + 0.5
)
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
#: How far a cell is pushed away from its neighbours' mean before thresholding: enough
#: to undo the blur between 2-3 px cells, not so much that noise flips a cell
#: (1 read fewer small markers and some false ids, 2 a false id; docs/benchmarks-history.md).
_SHARPEN = 1.5
#: The points read of each cell ``(81, 5, 2)`` and of the quiet zone ``(36, 2)``, as
#: fractions of the marker's side (the unit square the kernel maps onto each quad).
_CELL_SAMPLES = (_CELL_CENTRES[:, None, :] - 0.5 + _OFFSETS) / GRID
_QUIET_SAMPLES = _QUIET_UV / GRID
#: Corner order of a quad whose printed top-left corner is its corner k.
_ROLLS = np.array([[(k + i) % 4 for i in range(4)] for k in range(4)])
# Index in the 81 cells of each data cell, row by row as printed, when the
# marker's top-left corner is the quad's corner k: the inner 7x7 grid turned
# k quarter turns (np.rot90's sense), (4, 49).
_INNER = np.arange(GRID * GRID).reshape(GRID, GRID)[1:-1, 1:-1]
_TURNED = np.stack([np.rot90(_INNER, k).ravel() for k in range(4)])
_BORDER_CELLS = np.flatnonzero(_BORDER_FLAT)


def _linear_reading(cells: np.ndarray, quiet: np.ndarray) -> np.ndarray:
    """What is read of a candidate before its cells are called black or white, ``(N, 3 * 81 + 1)``.

    From the grey levels of its 81 cells ``(N, 81)`` and of the quiet zone
    ``(N, 36)``: each cell sharpened against its four neighbours, the
    threshold plane under it (the midpoint of the black and white planes),
    the black-white difference there, and the marker's contrast at its centre.
    Blur bleeds neighbouring cells into each other (a lone white cell of 2 px
    under 1 px of blur keeps about half its contrast), hence the sharpening;
    :func:`.kernels.read_markers` then calls a cell white when its sharpened
    level is above the threshold, with a margin (distance from the threshold
    as a fraction of the local difference: about 0.5 for a clear cell, near
    0 for a doubtful one).
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


# _linear_reading is linear: one matrix, built by applying it to unit vectors.
_N_READ = GRID * GRID + len(_QUIET_UV)
_READING_OP = _linear_reading(np.eye(_N_READ)[:, : GRID * GRID], np.eye(_N_READ)[:, GRID * GRID :])


@dataclass
class _Reading:
    """One decoded candidate: printed-order corners, id, bits corrected, ambiguity."""

    corners: np.ndarray
    marker_id: int
    corrected: int
    ambiguous: bool


class HammingTracker(Tracker):
    """Finds Hampy-format Hamming markers; one detection per physical marker.

    ``max_corrected_bits`` bounds the bits corrected over the seven rows; a
    correction may flip only a cell in doubt (read closer to the threshold than
    ``max_flip_margin``, a fraction of the local black-white difference), and a
    row is read only when its code word beats every other by ``min_row_gap``
    (summed margins): a clearly read wrong cell is an occluder or another
    marker, and a row nearly as close to two code words is a guess (docs/
    benchmarks-history.md, "Small markers"). ``max_border_errors`` is how many of the 32
    border cells may read white; ``only_registered`` drops ids the profile does
    not list. ``fine_search`` looks for candidates with a local threshold as well,
    and ``blur_fit`` reads small candidates the cells cannot be thresholded in by
    fitting blurred code words to them (:mod:`.hamming_blur`).
    """

    family = FAMILY
    marker_family = FAMILY

    def __init__(
        self,
        preprocessing: Preprocessing | None = None,
        roles: TagRoles | None = None,
        *,
        min_side_px: float = 10.0,
        max_corrected_bits: int = 2,
        max_border_errors: int = 1,
        min_contrast: float = 20.0,
        only_registered: bool = False,
        refine: bool = True,
        max_flip_margin: float = 0.25,
        min_row_gap: float = MIN_ROW_GAP,
        fine_search: bool = True,
        blur_fit: bool = True,
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
        self.min_row_gap = float(min_row_gap)
        self.fine_search = bool(fine_search)
        self.blur_fit = bool(blur_fit)
        self._fine = Preprocessing(**FINE_SEARCH)

    # -- the Tracker contract -------------------------------------------------

    def start(self) -> None:
        """Detect once in a made-up frame, so the first real frame costs what later ones do."""
        from .markers import warm_up

        warm_up(self, FAMILY)

    def detect(self, frame: Frame) -> list[Detection]:
        """Every Hamming marker in ``frame``; poses when its size and intrinsics are known.

        Sets :attr:`unread` (see :class:`armtree.api.rig.Tracker`).
        """
        gray = to_gray(frame.image)
        quads = self.candidates(gray)
        if self.refine and len(quads):
            # refined corners put the cell samples on the cells, which matters at 2-3 px per cell
            quads = refine_corners(gray, quads, GRID, contour_inset=0.5)
        readings, self.unread = self._decode(gray, quads)
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
        quads = dark_quads(dark, self.min_side_px)
        if self.fine_search:
            dark = mostly_dark(self._fine.apply(gray), FINE_MOST_LIGHT)
            fine = dark_quads(dark, self.min_side_px, hull_fallback=True)
            if len(quads) and len(fine):
                fine = fine[~_same_squares(fine, quads)]  # one candidate per marker
            quads = np.concatenate([quads, fine])
        return quads

    def decode(self, gray: np.ndarray, quads: np.ndarray) -> list[_Reading]:
        """Read, check and decode every candidate; one reading per accepted marker."""
        return self._decode(gray, quads)[0]

    def _decode(self, gray: np.ndarray, quads: np.ndarray) -> tuple[list[_Reading], int]:
        """:meth:`decode`'s readings, and how many marker-like candidates apart from them
        decoded as no id."""
        if len(quads) == 0:
            return [], 0
        if self.only_registered and not self.roles.table:
            return [], 0
        levels = sample_cells(
            np.ascontiguousarray(gray), quads.astype(np.float64), _CELL_SAMPLES, _QUIET_SAMPLES
        )
        reading = levels @ _READING_OP
        contrasted = reading[:, -1] >= self.min_contrast
        # under CELLS_MIN_SIDE_PX a side, cells are too small to call one by one
        shortest = np.linalg.norm(quads - np.roll(quads, 1, axis=1), axis=2).min(axis=1)
        small = shortest < CELLS_MIN_SIDE_PX
        cells_read = reading
        if small.any():
            cells_read = reading.copy()
            cells_read[small, -1] = -np.inf  # below min_contrast: read_markers skips it
        rows, turns, ids, corrected, ties, unread = read_markers(
            cells_read,
            _BORDER_CELLS,
            _TURNED,
            CODEWORDS,
            np.array(sorted(self.roles.table), dtype=np.int64),
            self.only_registered,
            self.min_contrast,
            self.max_border_errors,
            self.max_corrected_bits,
            self.max_flip_margin,
            self.min_row_gap,
        )
        corners = quads[rows[:, None], _ROLLS[turns]]
        if self.blur_fit:
            more, more_ids = self._fit_small(gray, quads, rows, contrasted)
            corners = np.concatenate([corners, more])
            ids = np.concatenate([ids, more_ids])
            # a fitted reading is the least sure: any reading of the cells wins over it
            corrected = np.concatenate([corrected, np.full(len(more_ids), 99)])
            ties = np.concatenate([ties, np.ones(len(more_ids), dtype=ties.dtype)])
        unseen = int(apart_from(quads[unread], corners).sum())
        if len(corners) == 0:
            return [], unseen
        # a dark sheet with a white window around a marker can itself read as a
        # marker with corrections; the marker in the window, read cleanly, is the one
        kept = best_of_overlapping(corners, corrected, ties > 1)
        readings = [
            _Reading(
                corners[i],
                int(ids[i]),
                int(min(corrected[i], self.max_corrected_bits)),
                bool(ties[i] > 1),
            )
            for i in kept
        ]
        return readings, unseen

    def _fit_small(
        self, gray: np.ndarray, quads: np.ndarray, read: np.ndarray, contrasted: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Printed-order corners ``(M, 4, 2)`` (as the fit refined them) and ids ``(M,)`` of
        the small candidates the cells left unread, with a white quiet zone around a dark
        border (``contrasted``), that blurred code words fit (:mod:`.hamming_blur`)."""
        sides = np.linalg.norm(quads - np.roll(quads, 1, axis=1), axis=2).mean(axis=1)
        small = (sides >= BLUR_FIT_MIN_SIDE_PX) & (sides <= BLUR_FIT_MAX_SIDE_PX) & contrasted
        small[read] = False
        picked = np.flatnonzero(small)
        if len(picked) == 0:
            return np.zeros((0, 4, 2), quads.dtype), np.zeros(0, dtype=np.int64)
        fit_ids, _, fitted = hamming_blur_reader().read(gray, quads[picked])
        ok = fit_ids >= 0
        if self.only_registered:
            ok &= np.isin(fit_ids, np.array(sorted(self.roles.table), dtype=np.int64))
        return fitted[ok].astype(quads.dtype), fit_ids[ok].astype(np.int64)


def _same_squares(quads: np.ndarray, others: np.ndarray) -> np.ndarray:
    """Which of ``quads (N, 4, 2)`` outline a square of ``others (M, 4, 2)`` again: centres
    within a quarter side and sides within 30 % (a marker inside a dark sheet is not its
    sheet)."""

    def centres_sides(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        sides = np.linalg.norm(q - np.roll(q, 1, axis=1), axis=2).mean(axis=1)
        return q.mean(axis=1), sides

    (c1, s1), (c2, s2) = centres_sides(quads), centres_sides(others)
    near = np.linalg.norm(c1[:, None] - c2[None], axis=2) < 0.25 * s2[None]
    ratio = s1[:, None] / np.maximum(s2[None], 1e-9)
    return (near & (ratio > 0.7) & (ratio < 1.3)).any(axis=1)


def _tracker(values: dict[str, Any], where: Any) -> HammingTracker:
    """The tracker a checked ``tracker:`` section describes (``where`` is the profile)."""
    return HammingTracker(
        Preprocessing.from_config(values["preprocess"], where),
        TagRoles.from_profile(where, values["size_mm"], FAMILY),
        min_side_px=values["min_side_px"],
        max_corrected_bits=values["max_corrected_bits"],
        max_border_errors=values["max_border_errors"],
        min_contrast=values["min_contrast"],
        only_registered=values["only_registered"],
        refine=values["refine"],
        max_flip_margin=values["max_flip_margin"],
        min_row_gap=values["min_row_gap"],
        fine_search=values["fine_search"],
        blur_fit=values["blur_fit"],
    )


def hamming_factory(config: dict[str, Any], context: RigContext) -> HammingTracker:
    """Hampy-format Hamming markers (9x9, 28-bit ids), Showers 2016's preprocessing by default."""
    values = check_config(config, _PARAMS, "tracker", context.profile)
    return _tracker(values, context.profile)


def _validate(config: dict[str, Any], profile: Profile) -> None:
    """Load-time checks (``armtree check``): build the tracker and run it once."""
    values = check_config(config, _PARAMS, "tracker", profile)
    probe(_tracker(values, profile), profile, "tracker.preprocess")


# mypy types a def as a plain callable, which has no attributes to set: the same function,
# typed as what it is once its members are set.
hamming_factory = cast(CheckedFactory[HammingTracker], hamming_factory)
hamming_factory.validate = _validate
_PARAMS: tuple[Param, ...] = (
    Param("preprocess", "dict", SEED_PREPROCESS, doc="threshold, adaptive, block_px, offset, blur"),
    Param(
        "size_mm",
        "float",
        None,
        unit="mm",
        doc="side of markers not listed in tags:",
        exclusive_minimum=0.0,
        maximum=10000.0,
    ),
    Param(
        "min_side_px",
        "float",
        10.0,
        unit="px",
        doc="smallest marker side looked for",
        minimum=1.0,
        maximum=10000.0,
    ),
    Param(
        "max_corrected_bits",
        "int",
        2,
        doc="bit corrections allowed per marker, one per row",
        minimum=0,
        maximum=9,
    ),
    Param(
        "max_border_errors",
        "int",
        1,
        doc="border cells allowed to read white",
        minimum=0,
        maximum=32,
    ),
    Param(
        "min_contrast",
        "float",
        20.0,
        doc="grey levels between a marker's black and white",
        minimum=0.0,
        maximum=255.0,
    ),
    Param("only_registered", "bool", False, doc="report only ids listed in the profile's tags:"),
    Param("refine", "bool", True, doc="sub-pixel corners from the square's edges"),
    Param(
        "max_flip_margin",
        "float",
        0.25,
        doc="cells read closer than this to the threshold are in doubt",
        minimum=0.0,
        maximum=0.5,
    ),
    Param("fine_search", "bool", True, doc="also look for markers with a 7 px local threshold"),
    Param("blur_fit", "bool", True, doc="read small blurred markers by fitting code words"),
    Param(
        "min_row_gap",
        "float",
        MIN_ROW_GAP,
        doc="how much better a row's code word must fit than any other (summed margins)",
        minimum=0.0,
        maximum=3.5,
    ),
)
hamming_factory.PARAMS = _PARAMS
