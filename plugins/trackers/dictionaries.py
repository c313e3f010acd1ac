"""OpenCV's predefined marker dictionaries by the names profiles use.

``4x4_50``, ``6x6_250``, ``apriltag_36h11``, ...: OpenCV's ``DICT_*`` constants
lower-cased without the prefix. The trackers, the marker drawings and the
families all read dictionaries here.
"""

from __future__ import annotations

from typing import Any

import cv2

from armtree.config.component_config import config_error
from armtree.errors import ConfigError, did_you_mean

APRILTAG = "apriltag"
DEFAULT_DICTIONARY = "4x4_50"
#: AprilTag families OpenCV's ArUco module carries, and the one most people print.
APRILTAG_FAMILIES = ("16h5", "25h9", "36h10", "36h11")
DEFAULT_APRILTAG = "36h11"


def dictionary_names() -> dict[str, int]:
    """Short dictionary name (``4x4_50``, ``apriltag_36h11``, ...) -> OpenCV's constant."""
    names: dict[str, int] = {}
    for attr in dir(cv2.aruco):
        if attr.startswith("DICT_"):
            names.setdefault(attr[5:].lower(), getattr(cv2.aruco, attr))
    return names


def get_dictionary(name: str, where: Any = None) -> cv2.aruco.Dictionary:
    """OpenCV's predefined dictionary called ``name`` (``4x4_50``, ``DICT_6X6_250``, ...).

    An unknown name is a :class:`ConfigError` with a did-you-mean (about the
    profile's ``tracker.dictionary`` when ``where`` is the profile).
    """
    names = dictionary_names()
    key = str(name).strip().lower()
    key = key.removeprefix("dict_")
    if key not in names:
        hint = did_you_mean(key, names, cutoff=0.5, list_up_to=len(names))
        message = f"unknown ArUco dictionary {name!r}{hint}"
        raise (
            ConfigError(message)
            if where is None
            else config_error(where, "tracker.dictionary", message)
        )
    return cv2.aruco.getPredefinedDictionary(names[key])


def dictionary_key(name: str) -> str:
    """A dictionary's name as families and ``tags: family_ids:`` spell it (``apriltag_36h11``)."""
    return str(name).strip().lower().removeprefix("dict_")
