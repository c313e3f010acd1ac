"""Marker images for the renderer, cached by family, dictionary, id and resolution.

The vision plugin's generator (``armtree.plugins.trackers.markers``) is used
when it is installed, so the sim draws exactly what the trackers read; ArUco
markers fall back to OpenCV's own generator without it.
"""

from __future__ import annotations

import importlib

import cv2
import numpy as np

from .scene import MarkerSpec

#: Resolutions (pixels per side) kept per marker; the renderer picks the one
#: just above the marker's size in the image so warping never aliases.
LEVELS = (16, 32, 64, 128, 256)


def _aruco_square(dictionary: str, marker_id: int, side: int) -> np.ndarray:
    name = dictionary.lower().removeprefix("dict_")
    attrs = [f"DICT_{name.upper()}"]
    if name.startswith("apriltag_"):
        attrs.append("DICT_APRILTAG_" + name.split("_", 1)[1])
    for attr in attrs:
        const = getattr(cv2.aruco, attr, None)
        if const is not None:
            d = cv2.aruco.getPredefinedDictionary(const)
            return cv2.aruco.generateImageMarker(d, int(marker_id), int(side), borderBits=1)
    raise ValueError(f"unknown ArUco dictionary {dictionary!r}")


def marker_square(spec: MarkerSpec, side: int) -> np.ndarray:
    """The marker's black square with its code, ``side`` pixels, grey uint8, no quiet zone."""
    try:
        vision = importlib.import_module("armtree.plugins.trackers.markers")
    except ImportError:
        vision = None
    if vision is not None and hasattr(vision, "marker_square"):
        return vision.marker_square(spec.family, spec.id, side, spec.dictionary)
    if spec.family == "aruco":
        return _aruco_square(spec.dictionary, spec.id, side)
    raise ValueError("hamming markers need the vision plugin (armtree.plugins.trackers.markers)")


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
