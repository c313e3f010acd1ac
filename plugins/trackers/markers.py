"""Printable marker images: ArUco (OpenCV's generator) and Hampy-format Hamming markers.

A marker's size is the side of its black square, border included: that is
the length the trackers use for the pose. Images carry a white quiet zone
around the square (one cell wide at least, so the border edge stands out on
any background) and are written with their DPI, so printing them at 100 %
gives the stated millimetres.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from armtree.api.rig import Frame

from . import hamming_code
from .dictionaries import get_dictionary

MM_PER_INCH = 25.4
#: A4 portrait, millimetres.
A4_MM = (210.0, 297.0)
FAMILIES = ("aruco", "hamming")


def cells_per_side(family: str, dictionary: str = "4x4_50") -> int:
    """Cells along one side of a marker of ``family``, border included."""
    if family == "hamming":
        return hamming_code.GRID
    return get_dictionary(dictionary).markerSize + 2


def marker_square(
    family: str, marker_id: int, side_px: int, dictionary: str = "4x4_50"
) -> np.ndarray:
    """The black square of a marker, ``side_px`` pixels across, grey uint8 (no quiet zone).

    Raises ``ValueError`` for an id the family or dictionary does not have.
    """
    if side_px < 1:
        raise ValueError(f"a marker needs at least one pixel, got {side_px}")
    if family == "hamming":
        grid = hamming_code.marker_grid(marker_id) * np.uint8(255)
        return cv2.resize(grid, (side_px, side_px), interpolation=cv2.INTER_NEAREST)
    if family == "aruco":
        d = get_dictionary(dictionary)
        count = d.bytesList.shape[0]
        if not 0 <= marker_id < count:
            raise ValueError(f"dictionary {dictionary} has ids 0 to {count - 1}, not {marker_id}")
        return cv2.aruco.generateImageMarker(d, int(marker_id), int(side_px), borderBits=1)
    raise ValueError(f"unknown marker family {family!r}; choose {' or '.join(FAMILIES)}")


def marker_image(
    family: str,
    marker_id: int,
    side_px: int,
    dictionary: str = "4x4_50",
    quiet_cells: float = 1.0,
) -> np.ndarray:
    """A marker with a white quiet zone of ``quiet_cells`` cells on every side, grey uint8."""
    square = marker_square(family, marker_id, side_px, dictionary)
    quiet = int(round(quiet_cells * side_px / cells_per_side(family, dictionary)))
    return cv2.copyMakeBorder(square, quiet, quiet, quiet, quiet, cv2.BORDER_CONSTANT, value=255)


@dataclass(frozen=True)
class PrintedMarker:
    """A marker image ready to print: pixels, DPI, and the size the square prints at."""

    image: np.ndarray
    dpi: float
    size_mm: float
    side_px: int


def printable_marker(
    family: str,
    marker_id: int,
    size_mm: float,
    dpi: float = 300.0,
    dictionary: str = "4x4_50",
    quiet_cells: float = 1.0,
) -> PrintedMarker:
    """A marker whose black square prints at ``size_mm`` at ``dpi`` (nearest whole pixel)."""
    if not size_mm > 0:
        raise ValueError(f"a marker size must be positive millimetres, got {size_mm}")
    if not dpi > 0:
        raise ValueError(f"dpi must be positive, got {dpi}")
    side_px = max(1, int(round(size_mm * dpi / MM_PER_INCH)))
    image = marker_image(family, marker_id, side_px, dictionary, quiet_cells)
    return PrintedMarker(image, dpi, side_px * MM_PER_INCH / dpi, side_px)


def write_png(path: str | Path, image: np.ndarray, dpi: float) -> None:
    """Write a grey image as PNG with its DPI recorded (matplotlib keeps the pHYs chunk)."""
    import matplotlib.image

    matplotlib.image.imsave(str(path), image, cmap="gray", vmin=0, vmax=255, dpi=dpi)


def write_sheet(
    path: str | Path,
    family: str,
    ids: Sequence[int],
    size_mm: float,
    dpi: float = 300.0,
    dictionary: str = "4x4_50",
    margin_mm: float = 12.0,
) -> int:
    """Lay out markers on A4 pages at ``size_mm`` with their ids under them; PNG or PDF.

    A PDF gets as many pages as needed; a PNG holds one page and raises
    ``ValueError`` when the ids do not fit on it. Returns the number of pages.
    """
    from matplotlib.backends.backend_pdf import PdfPages
    from matplotlib.figure import Figure

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".png", ".pdf"):
        raise ValueError(f"a sheet is written as .png or .pdf, not {path.name}")
    if not size_mm > 0:
        raise ValueError(f"a marker size must be positive millimetres, got {size_mm}")
    cells = cells_per_side(family, dictionary)
    pitch = size_mm * (1.0 + 2.0 / cells) + 8.0  # quiet zone both sides, and room for the label
    cols = int((A4_MM[0] - 2 * margin_mm) // pitch)
    rows = int((A4_MM[1] - 2 * margin_mm) // pitch)
    if cols < 1 or rows < 1:
        raise ValueError(f"a {size_mm} mm marker does not fit on an A4 page")
    per_page = cols * rows
    pages = [list(ids[i : i + per_page]) for i in range(0, len(ids), per_page)] or [[]]
    if suffix == ".png" and len(pages) > 1:
        raise ValueError(
            f"{len(ids)} markers of {size_mm} mm need {len(pages)} A4 pages; "
            f"one PNG holds {per_page}: write a .pdf"
        )
    side_px = max(cells, int(round(size_mm * dpi / MM_PER_INCH)))
    figures = []
    for page in pages:
        fig = Figure(figsize=(A4_MM[0] / MM_PER_INCH, A4_MM[1] / MM_PER_INCH))
        for n, marker_id in enumerate(page):
            r, c = divmod(n, cols)
            x = margin_mm + c * pitch + (pitch - size_mm) / 2
            y_top = margin_mm + r * pitch + size_mm / cells
            ax = fig.add_axes(
                (
                    x / A4_MM[0],
                    1 - (y_top + size_mm) / A4_MM[1],
                    size_mm / A4_MM[0],
                    size_mm / A4_MM[1],
                )
            )
            ax.imshow(
                marker_square(family, marker_id, side_px, dictionary),
                cmap="gray",
                vmin=0,
                vmax=255,
                interpolation="nearest",
            )
            ax.set_axis_off()
            label = f"{dictionary if family == 'aruco' else family} id {marker_id}"
            fig.text(
                (x + size_mm / 2) / A4_MM[0],
                1 - (y_top + size_mm + size_mm / cells + 1.0) / A4_MM[1],
                f"{label}, {size_mm:g} mm",
                ha="center",
                va="top",
                fontsize=6,
            )
        figures.append(fig)
    if suffix == ".pdf":
        with PdfPages(str(path)) as pdf:
            for fig in figures:
                pdf.savefig(fig, dpi=dpi)
    else:
        figures[0].savefig(str(path), dpi=dpi)
    return len(pages)


def warm_up(tracker: Any, family: str, dictionary: str = "4x4_50") -> None:
    """Run ``tracker`` once on a frame holding one marker (id 1) of its family.

    What the first detection loads or compiles is then done when the rig starts,
    not inside the first tick that sees a marker (on the wall clock such a tick
    would starve the serial link's thread).
    """
    image = np.full((480, 640, 3), 200, np.uint8)
    marker = marker_image(family, 1, 120, dictionary)  # id 1: both families read it
    image[180 : 180 + marker.shape[0], 260 : 260 + marker.shape[1]] = marker[..., None]
    k = np.array([[640.0, 0.0, 319.5], [0.0, 640.0, 239.5], [0.0, 0.0, 1.0]])
    tracker.detect(Frame(image=image, timestamp=0.0, camera_matrix=k, distortion=np.zeros(5)))
