"""Image preprocessing before marker detection, as the Dobot report measured it.

Showers 2016, "Marker Detection": grey-scaling, thresholding to full black/white at
40 % of full scale and a slight Gaussian blur raised the marker detection rate
from 9.79 to 14.10 markers/s for a moving marker with moving shadows. Both
trackers take the same ``preprocess:`` mapping from the profile:

``threshold``  fraction of full scale (0 < t < 1) for global binarisation, or null
``adaptive``   binarise against the local mean instead (uneven light)
``block_px``   neighbourhood of the adaptive threshold (odd, pixels)
``offset``     how far below the local mean a pixel must be to count as black
``blur``       Gaussian kernel size after binarising (odd pixels, 0 for none)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from armtree.config.component_config import check_config, config_error
from armtree.config.params import Param

from .kernels import clockwise_quads

#: The keys of a ``preprocess:`` mapping.
PREPROCESS_PARAMS: tuple[Param, ...] = (
    Param(
        "threshold",
        "float",
        None,
        doc="global threshold, fraction of full scale (0.4 in Showers 2016)",
    ),
    Param("adaptive", "bool", False, doc="adaptive (local mean) thresholding instead"),
    Param("block_px", "int", 31, unit="px", doc="adaptive threshold neighbourhood, odd"),
    Param(
        "offset", "float", 7.0, doc="adaptive threshold offset below the local mean (grey levels)"
    ),
    Param(
        "blur", "int", 0, unit="px", doc="Gaussian blur kernel after thresholding, odd, 0 = none"
    ),
)


@dataclass(frozen=True)
class Preprocessing:
    """What to do to a frame before a tracker looks for markers; see the module docstring."""

    threshold: float | None = None
    adaptive: bool = False
    block_px: int = 31
    offset: float = 7.0
    blur: int = 0

    @property
    def binarises(self) -> bool:
        """True when the output is a black/white (possibly blurred) image."""
        return self.adaptive or self.threshold is not None

    @property
    def identity(self) -> bool:
        """True when the output is the plain grey image."""
        return not self.binarises and self.blur == 0

    @classmethod
    def from_config(cls, config: Any, where: Any = None) -> Preprocessing:
        """Validate a profile's ``preprocess:`` mapping (None for none); ConfigError names the key."""
        values = check_config(config, PREPROCESS_PARAMS, "tracker.preprocess", where)
        prep = cls(**values)
        if prep.threshold is not None and not 0.0 < prep.threshold < 1.0:
            raise config_error(
                where,
                "tracker.preprocess.threshold",
                f"a fraction of full scale between 0 and 1 (0.4 in Showers 2016), got {prep.threshold}",
            )
        if prep.block_px < 3 or prep.block_px % 2 == 0:
            raise config_error(
                where, "tracker.preprocess.block_px", f"an odd number >= 3, got {prep.block_px}"
            )
        if prep.blur < 0 or (prep.blur and prep.blur % 2 == 0):
            raise config_error(
                where, "tracker.preprocess.blur", f"0 or an odd kernel size, got {prep.blur}"
            )
        return prep

    def apply(self, gray: np.ndarray) -> np.ndarray:
        """The preprocessed image of a grey ``uint8`` image (the input itself when identity)."""
        out = self._binarise(gray)
        if self.blur:
            out = cv2.GaussianBlur(out, (self.blur, self.blur), 0)
        return out

    def dark(self, gray: np.ndarray) -> np.ndarray:
        """255 where :meth:`apply`'s image is dark (at most 127), else 0; only when it binarises.

        The same pixels as thresholding :meth:`apply`'s output at 127, computed
        without the blur for Showers 2016's 3 px one (see :func:`dark_after_blur3`).
        """
        if not self.binarises:
            raise ValueError("dark() needs a binarising preprocessing (threshold or adaptive)")
        if self.blur == 3 and min(gray.shape) >= 3:
            if self.adaptive:
                return dark_after_blur3(self._binarise(gray))
            # the global threshold, and the one dark_after_blur3 applies, in one
            assert self.threshold is not None  # binarises, and not adaptively
            return dark_after_blur3(gray, 255.0 * self.threshold)
        binary = self._binarise(gray)
        if self.blur:
            binary = cv2.GaussianBlur(binary, (self.blur, self.blur), 0)
        return threshold_image(binary, 127, cv2.THRESH_BINARY_INV)

    def _binarise(self, gray: np.ndarray) -> np.ndarray:
        if self.adaptive:
            return cv2.adaptiveThreshold(
                gray,
                255,
                cv2.ADAPTIVE_THRESH_MEAN_C,
                cv2.THRESH_BINARY,
                self.block_px,
                self.offset,
            )
        if self.threshold is not None:
            # Showers 2016: decision boundary at a fraction (40 %) of full pixel strength
            return threshold_image(gray, 255.0 * self.threshold, cv2.THRESH_BINARY)
        return gray


def to_gray(image: np.ndarray) -> np.ndarray:
    """A grey ``uint8`` view of a BGR, BGRA or grey image; ValueError for anything else."""
    image = np.asarray(image)
    if image.dtype != np.uint8:
        raise ValueError(f"expected an 8-bit image, got dtype {image.dtype}")
    if image.ndim == 2:
        return image
    if image.ndim == 3 and image.shape[2] in (3, 4):
        code = cv2.COLOR_BGR2GRAY if image.shape[2] == 3 else cv2.COLOR_BGRA2GRAY
        # as one row of pixels (see threshold_image): the same grey levels, no worker threads
        return cv2.cvtColor(image.reshape(1, -1, image.shape[2]), code).reshape(image.shape[:2])
    if image.ndim == 3 and image.shape[2] == 1:
        return image[:, :, 0]
    raise ValueError(f"expected a grey or BGR image, got shape {image.shape}")


def threshold_image(gray: np.ndarray, level: float, kind: int) -> np.ndarray:
    """``cv2.threshold(gray, level, 255, kind)``'s image, computed as one row of pixels.

    OpenCV splits per-pixel work by rows between its threads; on a 640x480
    frame waking them, and their spinning afterwards, costs more CPU time than
    the work itself. The result is the same pixel for pixel (Otsu's level too).
    """
    _, out = cv2.threshold(gray.reshape(1, -1), level, 255, kind)
    return out.reshape(gray.shape)


def dark_after_blur3(image: np.ndarray, level: float = 127.0) -> np.ndarray:
    """255 where ``image`` binarised at ``level`` is dark after OpenCV's 3x3 Gaussian blur.

    With ``binary = threshold(image, level, 255, THRESH_BINARY)``, exactly
    ``threshold(GaussianBlur(binary, (3, 3), 0), 127, 255, THRESH_BINARY_INV)``
    for images of at least 3x3 (a 0/255 image binarises to itself at 127): the
    blur's kernel is (1 2 1) x (1 2 1) / 16, so a pixel ends up dark when the
    weighted count of white pixels around it is at most 7 of 16 (8 rounds to 128).
    """
    return mostly_dark(image, 7, level)


def mostly_dark(image: np.ndarray, most_light: int, level: float = 127.0) -> np.ndarray:
    """255 where at most ``most_light`` of 16 of the 3x3 neighbourhood of ``image``
    binarised at ``level`` (a ``uint8`` image, at least 2x2) is light, weighed as
    OpenCV's 3x3 Gaussian weighs it ((1 2 1) x (1 2 1), borders mirrored without
    repeating the edge, OpenCV's default); else 0.

    At 7 this is :func:`dark_after_blur3` (Showers 2016's blur, then half way): a dark
    line one pixel wide (8 of 16 light) goes. From 8 up it stays, while a lone dark
    pixel (12 of 16) or two side by side (10) still go. The sums are in-place
    additions of the image shifted by one pixel and by one row: no worker threads
    and two frame buffers, where the blur costs more CPU time in its threads than in
    its arithmetic.
    """
    h, w = image.shape
    _, ones = cv2.threshold(image.reshape(1, -1), level, 1, cv2.THRESH_BINARY)
    flat = ones.reshape(-1)
    # where a shift ran from one row into the next (the first and last columns and
    # rows) is redone after
    across = np.empty(h * w, np.uint8)  # 1 2 1 along each row
    inner = across[1:-1]
    np.add(flat[:-2], flat[2:], out=inner)
    inner += flat[1:-1]
    inner += flat[1:-1]
    rows, grid = across.reshape(h, w), flat.reshape(h, w)
    rows[:, 0] = 2 * (grid[:, 0] + grid[:, min(1, w - 1)])
    rows[:, -1] = 2 * (grid[:, -1] + grid[:, max(w - 2, 0)])
    total = flat  # then 1 2 1 down each column, over the no longer needed ones
    inner = total[w:-w]
    np.add(across[: -2 * w], across[2 * w :], out=inner)
    inner += across[w:-w]
    inner += across[w:-w]
    grid[0] = 2 * (rows[0] + rows[min(1, h - 1)])
    grid[-1] = 2 * (rows[-1] + rows[max(h - 2, 0)])
    cv2.threshold(ones, most_light, 255, cv2.THRESH_BINARY_INV, dst=ones)
    return grid


#: Corners of a simplified outline that :func:`dark_quads` still tries as a ragged square.
HULL_MAX_VERTICES = 12
#: ... and its largest perimeter (px): a larger marker's outline is not ragged but
#: broken (a covered marker), and its hull would be read as the whole marker.
HULL_MAX_PERIMETER_PX = 128.0
#: Its tolerance simplifying the hull, a fraction of the hull's perimeter.
HULL_EPSILON = 0.05


def dark_quads(dark: np.ndarray, min_side_px: float, hull_fallback: bool = False) -> np.ndarray:
    """Convex quadrilaterals ``(N, 4, 2)`` float32, clockwise on screen, outlining the dark
    regions of ``dark`` (255 where dark) with every side at least ``min_side_px`` long:
    the shapes a square marker's black border makes.

    With ``hull_fallback``, a small outline (:data:`HULL_MAX_PERIMETER_PX`) that does not
    simplify to a convex quad but to at most :data:`HULL_MAX_VERTICES` corners is
    simplified again from its convex hull:
    at under two pixels a cell, noise and blur make a marker's outline ragged, and its
    hull is the square again. The fill check still keeps blobs out."""
    # findContoursLinkRuns gives what RETR_CCOMP with CHAIN_APPROX_SIMPLE gives,
    # without findContours' internal full-frame threshold on OpenCV's worker threads.
    contours, _ = cv2.findContoursLinkRuns(dark)
    min_perimeter = 4.0 * min_side_px
    h, w = dark.shape
    max_perimeter = 2.0 * (w + h)
    min_area = 0.5 * min_side_px**2
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
        square = len(approx) == 4 and cv2.isContourConvex(approx)
        ragged = len(approx) <= HULL_MAX_VERTICES and perimeter <= HULL_MAX_PERIMETER_PX
        if not square and hull_fallback and ragged:
            hull = cv2.convexHull(contour)
            approx = cv2.approxPolyDP(hull, HULL_EPSILON * cv2.arcLength(hull, True), True)
            square = len(approx) == 4 and cv2.isContourConvex(approx)
        if not square:
            continue
        # a square's outline fills its quad; a blob's (an ellipse, a hand) does not
        fill = area / max(cv2.contourArea(approx), 1.0)
        if 0.8 < fill < 1.2:
            found.append(approx)
    if not found:
        return np.zeros((0, 4, 2), np.float32)
    quads = np.concatenate(found).reshape(-1, 4, 2).astype(np.float32)
    return clockwise_quads(quads, float(min_side_px))
