"""Marker images for the renderer, cached by family, dictionary, id and resolution.

The images come from the trackers plugin's generator
(``armtree.plugins.trackers.markers``), so the sim draws exactly what the
trackers read and what ``armtree markers`` prints.
"""

from __future__ import annotations

import numpy as np

from armtree.plugins.trackers.markers import marker_square as generated_marker

from .scene_spec import MarkerSpec

#: Resolutions (pixels per side) kept per marker; the renderer picks the one
#: just above the marker's size in the image so warping never aliases.
LEVELS = (16, 32, 64, 128, 256)


def marker_square(spec: MarkerSpec, side: int) -> np.ndarray:
    """The marker's black square with its code, ``side`` pixels, grey uint8, no quiet zone."""
    return generated_marker(spec.family, spec.id, side, spec.dictionary)


class MarkerAtlas:
    """Marker images at several resolutions; black is 1, not 0, so 0 can mean 'outside'."""

    def __init__(self) -> None:
        self._cache: dict[tuple[str, str, int, int], np.ndarray] = {}

    def image(self, spec: MarkerSpec, side_px: float) -> np.ndarray:
        """The smallest cached level at least ``side_px`` pixels wide (the largest if none)."""
        level = next((n for n in LEVELS if n >= side_px), LEVELS[-1])
        key = (spec.family, spec.dictionary, spec.id, level)
        img = self._cache.get(key)
        if img is None:
            # Printed black is never perfectly black; 1..235 keeps 0 free for the mask.
            square = marker_square(spec, level).astype(np.float32)
            img = (1 + square * (234.0 / 255.0)).astype(np.uint8)
            self._cache[key] = img
        return img
