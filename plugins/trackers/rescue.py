"""A second reading of the candidates OpenCV's ArUco detector rejected, on refined corners.

At three to four pixels a cell (a 25 mm marker seen from 650 mm through a 570 px
lens) OpenCV's decoder, which reads the cells between the corners of the
candidate's contour, now and then misreads a marker whose cells straddle pixel
boundaries, and rejects it, in every frame while nothing moves. Here each
rejected candidate of at most :data:`MAX_SIDE_PX` gets its corners from its
four edges (:mod:`.refine`), its cells are read in their middles
(:func:`.kernels.sample_cells`), its border must be black, and its inside must
be a word of the dictionary exactly, under one of the four turns: no bit is
corrected, so a rescued marker is as sure as OpenCV's. A candidate whose cells
no threshold reads (two pixels a cell under blur) is read by fitting every
word of the dictionary, blurred, to its levels (:mod:`.blur_decode`).

The same first look (:meth:`Rescuer.marker_like`: a dark border around light
cells) tells the tracker's ``unread`` count which shapes look like markers.
"""

from __future__ import annotations

import cv2
import numpy as np

from .blur_decode import BlurFitReader, blur_fit_reader
from .kernels import clockwise_quads, sample_cells
from .refine import refine_corners

#: Largest candidate side (px) read again; OpenCV reads larger markers reliably.
MAX_SIDE_PX = 64.0
#: Least grey-level difference between the border and the white cells.
MIN_CONTRAST = 40.0
#: Least distance of a cell's level from the threshold, as a fraction of the contrast.
MIN_MARGIN = 0.08
#: Where each cell is read, as fractions of the cell (a 3 x 3 grid in its middle).
_IN_CELL = np.array([0.4, 0.5, 0.6])


class Rescuer:
    """Reads rejected candidates of one dictionary again; see the module's docstring."""

    def __init__(self, dictionary: cv2.aruco.Dictionary) -> None:
        n = int(dictionary.markerSize)
        self.bits = n
        self.cells = n + 2
        words = []
        for marker_id in range(len(dictionary.bytesList)):
            canonical = cv2.aruco.Dictionary.getBitsFromByteList(
                dictionary.bytesList[marker_id : marker_id + 1], n
            )
            for turn in range(4):
                words.append(np.rot90(canonical, turn).reshape(-1))
        #: (ids * 4, n * n): each id's inside as it reads with its top-left corner turned.
        self.words = np.array(words, dtype=np.uint8)
        c = self.cells
        u, v = np.meshgrid(_IN_CELL, _IN_CELL, indexing="xy")
        inside = np.column_stack([u.ravel(), v.ravel()])
        rows, cols = np.divmod(np.arange(c * c), c)
        self.cell_uv = (np.stack([cols, rows], axis=1)[:, None, :] + inside[None]) / c
        ring = np.ones((c, c), dtype=bool)
        ring[1:-1, 1:-1] = False
        self.border = ring.reshape(-1)
        self._blurred: BlurFitReader | None = None  # built when first needed

    def __call__(
        self, gray: np.ndarray, rejected: np.ndarray, found: np.ndarray, min_side: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Markers among ``rejected`` quads ``(N, 4, 2)``: their quads (contour corners, turned
        so that corner 0 is the marker's top-left, as OpenCV's) and ids. ``found`` ``(M, 4, 2)``
        are the markers already detected (a candidate on one is skipped); ``min_side`` px."""
        none = np.zeros((0, 4, 2), np.float32), np.zeros(0, dtype=int)
        if len(rejected) == 0:
            return none
        quads = clockwise_quads(np.asarray(rejected, np.float32).reshape(-1, 4, 2), min_side)
        sides = np.linalg.norm(quads - np.roll(quads, -1, axis=1), axis=2)
        keep = sides.max(axis=1) <= MAX_SIDE_PX
        if len(found):
            centres = np.asarray(found, np.float32).reshape(-1, 4, 2).mean(axis=1)
            gap = np.linalg.norm(quads.mean(axis=1)[:, None] - centres[None], axis=2)
            keep &= np.all(gap > 0.5 * sides.min(axis=1)[:, None], axis=1)
        quads = quads[keep]
        if len(quads) == 0:
            return none
        # a first look on the contour's corners: most candidates (texture, a sheet's
        # outline) have no dark border with light cells inside and are not refined
        likely = self.marker_like(gray, quads)
        quads, sides = quads[likely], sides[keep][likely]
        if len(quads) == 0:
            return none
        refined = refine_corners(gray, quads, self.cells, contour_inset=0.5)
        levels, threshold, contrast = self._read(gray, refined)
        clear = np.abs(levels - threshold) >= MIN_MARGIN * contrast[:, None]
        ok = (contrast >= MIN_CONTRAST) & np.all(clear, axis=1)
        ok &= np.all(levels[:, self.border] < threshold, axis=1)
        white = (levels[:, ~self.border] > threshold).astype(np.uint8)
        match = np.all(white[:, None, :] == self.words[None], axis=2)  # (N, ids * 4)
        ok &= match.sum(axis=1) == 1
        read_id, read_turn = np.divmod(np.argmax(match, axis=1), 4)
        # what no threshold reads, read as a whole blurred pattern
        unread = np.flatnonzero(~ok & (contrast >= MIN_CONTRAST))
        if len(unread):
            if self._blurred is None:
                self._blurred = blur_fit_reader(self.words)
            fit_id, fit_turn = self._blurred.read(gray, refined[unread])
            fitted = fit_id >= 0
            read_id[unread[fitted]], read_turn[unread[fitted]] = fit_id[fitted], fit_turn[fitted]
            ok[unread[fitted]] = True
        out_q, out_id, centres = [], [], []
        for k in np.flatnonzero(ok):
            marker_id, turn = int(read_id[k]), int(read_turn[k])
            centre = quads[k].mean(axis=0)
            if any(np.linalg.norm(centre - c) < 0.5 * sides[k].min() for c in centres):
                continue  # two contours of one marker
            centres.append(centre)
            # read = the marker turned by ``turn`` quarter turns: its corner c is quad corner c - turn
            out_q.append(np.roll(quads[k], turn, axis=0))
            out_id.append(marker_id)
        if not out_q:
            return none
        return np.array(out_q, dtype=np.float32), np.array(out_id, dtype=int)

    def marker_like(self, gray: np.ndarray, quads: np.ndarray) -> np.ndarray:
        """Which quads ``(N, 4, 2)`` look like a marker read at this dictionary's grid on
        their corners as given: most border cells dark, and light cells inside."""
        if len(quads) == 0:
            return np.zeros(0, dtype=bool)
        levels, threshold, contrast = self._read(gray, quads)
        dark_border = (levels[:, self.border] < threshold).mean(axis=1)
        return (contrast >= MIN_CONTRAST) & (dark_border >= 0.75)

    def _read(self, gray: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, ...]:
        """Each quad's cell levels ``(N, cells**2)``, the threshold ``(N, 1)`` halfway between
        its border's mean and its lightest inner cell, and that difference ``(N,)``."""
        levels = sample_cells(gray, np.asarray(quads, np.float64), self.cell_uv, np.zeros((0, 2)))
        dark = levels[:, self.border].mean(axis=1)
        light = levels[:, ~self.border].max(axis=1)
        return levels, 0.5 * (dark + light)[:, None], light - dark


__all__ = ["MAX_SIDE_PX", "MIN_CONTRAST", "Rescuer"]
