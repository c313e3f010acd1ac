"""Sub-pixel marker corners from the four edges of the black square.

OpenCV's ``cornerSubPix`` looks at the corner itself, where a blurred L
shape pulls the estimate towards the dark side by 0.1 to 0.3 px. Here each
edge is located instead, at many points away from the corners, each from a
short intensity profile across it: with the dark and light levels taken at
the profile's ends, the edge lies where the area under the normalised
profile says a step would be (``e = w - integral of the light fraction``),
which is exact for any symmetric blur and averages noise out. A line is
fitted through each edge's points and the corners are the intersections of
neighbouring lines. Every marker's profiles are sampled at once (:mod:`.kernels`),
with exact bilinear interpolation (``cv2.remap``'s is quantised to 1/32 px).

The profiles reach ``0.8`` of a cell inwards (so they stay on the black
border, whatever the bits inside) and as far outwards (into the quiet zone).
"""

from __future__ import annotations

import numpy as np

from .kernels import refine_quads

#: Points along each edge (avoiding the corners' rounded ends) and samples per profile.
_T = np.linspace(0.15, 0.85, 10)
_S = np.linspace(-1.0, 1.0, 13)
#: Trapezoid-rule weights over a profile's samples, in units of the reach.
_TRAPEZOID = np.full(len(_S), _S[1] - _S[0])
_TRAPEZOID[[0, -1]] *= 0.5
_MIN_CONTRAST = 8.0


def refine_corners(
    image: np.ndarray, quads: np.ndarray, cells: int, passes: int = 2, contour_inset: float = 0.0
) -> np.ndarray:
    """Refined corners ``(N, 4, 2)`` float32 of quads ``(N, 4, 2)`` running clockwise on screen.

    ``image`` is the grey frame, or the BGR one (read as grey, weighed as
    ``cv2.cvtColor`` weighs it). ``cells`` is the number of cells across a
    marker (border included), which bounds how far a profile may reach. A
    further pass (up to ``passes``) is made only for markers whose corners
    moved so far that the first profiles ended within the blur of the edge.
    Corners whose edges cannot be measured (no contrast, off the image) are
    left as they were. ``contour_inset`` (px) says how far inside both edges the
    given corners sit: corners taken from a dark region's contour run through
    its outermost pixel centres, half a pixel inside the edge; they are pushed
    out first, which usually saves the second pass.
    """
    quads = np.ascontiguousarray(quads, dtype=np.float64).reshape(-1, 4, 2)
    if len(quads) == 0:
        return quads.astype(np.float32)
    out = refine_quads(
        np.ascontiguousarray(image),
        quads,
        float(cells),
        int(passes),
        float(contour_inset),
        _T,
        _S,
        _TRAPEZOID,
        _MIN_CONTRAST,
    )
    return out.astype(np.float32)
