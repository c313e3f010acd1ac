"""Marker families: their names, their ids, which ids are valid, and which one a tracker reads.

A family is named as ``tags: ROLE: family_ids:``, ``armtree markers --family`` and
a tracker's ``marker_family`` name it: ``hamming`` (the Hampy format, Showers 2016),
or an ArUco dictionary as OpenCV names it (``4x4_50``, ``apriltag_36h11``, ...).
Every id of an ArUco dictionary is valid (OpenCV's dictionaries are built so
that no marker reads as another under any turn); a Hampy id is valid when its
orientation is unique (:func:`.hamming_code.id_problem`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from armtree.errors import ConfigError, did_you_mean

from . import hamming_code
from .dictionaries import (
    APRILTAG_FAMILIES,
    DEFAULT_APRILTAG,
    DEFAULT_DICTIONARY,
    dictionary_key,
    dictionary_names,
    get_dictionary,
)

HAMMING = "hamming"


@dataclass(frozen=True)
class MarkerFamily:
    """One family: its name, the generator that draws it (``hamming`` or ``aruco``),
    the ArUco dictionary (aruco only) and how many ids it has (0 to ``count - 1``)."""

    name: str
    generator: str
    dictionary: str
    count: int

    def id_problem(
        self, marker_id: int, max_corrected_bits: int = hamming_code.DEFAULT_MAX_CORRECTED
    ) -> str | None:
        """Why ``marker_id`` cannot be a marker of this family, or None when it can."""
        if not 0 <= marker_id < self.count:
            last = "2**28 - 1" if self.generator == HAMMING else str(self.count - 1)
            return f"{self.name} has ids 0 to {last}"
        if self.generator == HAMMING:
            return hamming_code.id_problem(int(marker_id), max_corrected_bits)
        return None

    def valid_ids_near(
        self,
        marker_id: int,
        count: int = 3,
        max_corrected_bits: int = hamming_code.DEFAULT_MAX_CORRECTED,
    ) -> list[int]:
        """The ``count`` valid ids nearest ``marker_id``."""
        if self.generator == HAMMING:
            return hamming_code.valid_ids_near(marker_id, count, max_corrected_bits)
        centre = min(max(int(marker_id), 0), self.count - 1)
        ordered = sorted(range(self.count), key=lambda i: (abs(i - centre), i))
        return ordered[:count]

    def id_error(
        self,
        marker_id: int,
        max_corrected_bits: int = hamming_code.DEFAULT_MAX_CORRECTED,
        taken: frozenset[int] = frozenset(),
    ) -> str | None:
        """``"hamming id 0 cannot be read: ...; valid ids near it: 275, 277, 279"`` or None.

        ``taken`` ids (other roles') are not offered as alternatives.
        """
        problem = self.id_problem(marker_id, max_corrected_bits)
        if problem is None:
            return None
        near = [
            i
            for i in self.valid_ids_near(marker_id, 3 + len(taken), max_corrected_bits)
            if i not in taken
        ][:3]
        what = (
            f"{problem}, not {marker_id}"
            if not 0 <= marker_id < self.count
            else f"{self.name} id {marker_id} cannot be read: {problem}"
        )
        return f"{what}; valid ids near it: {', '.join(map(str, near))}"


def family_names() -> list[str]:
    """Every family name: ``hamming`` and OpenCV's ArUco dictionaries."""
    return [HAMMING, *sorted(dictionary_names())]


def family_named(name: str) -> MarkerFamily:
    """The family called ``name`` (``hamming``, ``4x4_50``, ``DICT_APRILTAG_36h11``, ...).

    An unknown name is a :class:`ConfigError` with a did-you-mean.
    """
    key = str(name).strip().lower()
    if key == HAMMING:
        return MarkerFamily(HAMMING, HAMMING, "", hamming_code.MAX_ID)
    key = dictionary_key(key)
    if key not in dictionary_names():
        names = family_names()
        hint = did_you_mean(key, names, cutoff=0.5, list_up_to=len(names))
        raise ConfigError(f"unknown marker family {name!r}: hamming or an ArUco dictionary{hint}")
    return MarkerFamily(key, "aruco", key, int(get_dictionary(key).bytesList.shape[0]))


def apriltag_dictionary(family: str) -> str:
    """The ArUco dictionary of AprilTag family ``family`` (``36h11`` -> ``apriltag_36h11``).

    ConfigError naming the families for anything else.
    """
    key = str(family).strip().lower().removeprefix("tag").removeprefix("apriltag_")
    if key not in APRILTAG_FAMILIES:
        raise ConfigError(
            f"unknown AprilTag family {family!r}; OpenCV reads {', '.join(APRILTAG_FAMILIES)}"
        )
    return f"apriltag_{key}"


def tracker_family(config: Any) -> MarkerFamily | None:
    """The family a profile's ``tracker:`` section reads, or None when it does not say
    (no tracker, another plugin's tracker, a dictionary OpenCV does not have)."""
    if not isinstance(config, Mapping):
        return None
    kind = config.get("type")
    try:
        if kind == HAMMING:
            return family_named(HAMMING)
        if kind == "aruco":
            return family_named(str(config.get("dictionary") or DEFAULT_DICTIONARY))
        if kind == "apriltag":
            return family_named(apriltag_dictionary(config.get("family") or DEFAULT_APRILTAG))
    except ConfigError:
        return None
    return None


def max_corrected_bits(config: Any) -> int:
    """The corrections a ``tracker:`` section allows a Hampy marker (the hamming tracker's
    ``max_corrected_bits``; the default for any other tracker)."""
    if isinstance(config, Mapping) and config.get("type") == HAMMING:
        value = config.get("max_corrected_bits")
        if isinstance(value, int) and not isinstance(value, bool):
            return value
    return hamming_code.DEFAULT_MAX_CORRECTED


__all__ = [
    "HAMMING",
    "MarkerFamily",
    "apriltag_dictionary",
    "family_named",
    "family_names",
    "max_corrected_bits",
    "tracker_family",
]
