"""The ``aruco`` and ``apriltag`` trackers: OpenCV's ArucoDetector, any predefined dictionary.

``{type: apriltag, family: 36h11}`` is this tracker with the dictionary
``apriltag_36h11`` (OpenCV carries AprilTag 16h5, 25h9, 36h10 and 36h11 as
ArUco dictionaries), so ``{type: aruco, dictionary: apriltag_36h11}`` is the
same tracker spelled the long way (docs/trackers.md).

Durovic 2017 tracks its marker with ArUco; Showers 2016 solves the marker pose with
solvePnP. Corners are refined to sub-pixel accuracy by default from the
marker's four edges on the grey image (``refine: edges``, :mod:`.refine`),
which is several times more accurate than OpenCV's corner-based method on
blurred corners; ``refine: opencv`` keeps the detector's own refinement
(``detector: {cornerRefinementMethod: ...}``, sub-pixel by default). When the
profile's preprocessing binarises the image (Showers 2016's threshold and blur),
markers are found in the preprocessed image and refined on the grey one,
where the edges still carry sub-pixel information. Small candidates OpenCV
rejected are read again on their refined corners (``rescue``, :mod:`.rescue`):
at three to four pixels a cell its decoder misses some markers in every frame.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, cast

import cv2
import numpy as np

from armtree.api.component_factory import CheckedFactory
from armtree.api.rig import Detection, Frame, RigContext, Tracker
from armtree.config.component_config import check_config, config_error
from armtree.config.params import Param
from armtree.errors import did_you_mean
from armtree.loader.profile import Profile

from .common import TagRoles, finish_detection, probe
from .dictionaries import (
    APRILTAG,
    APRILTAG_FAMILIES,
    DEFAULT_APRILTAG,
    DEFAULT_DICTIONARY,
    dictionary_key,
    get_dictionary,
)
from .kernels import apart_from, framed_by_light
from .markers import warm_up
from .preprocess import Preprocessing, dark_quads, threshold_image, to_gray
from .refine import refine_corners
from .rescue import Rescuer

FAMILY = "aruco"
#: Pixels per cell when reading a candidate's bits (OpenCV's default is 4).
SMALL_MARKER_PIXELS_PER_CELL = 8
#: Least :func:`.kernels.framed_by_light` of a marker: a printed one's quiet zone is
#: about as light as its white cells, a light blob in a dark patch's is not (docs/
#: benchmarks-history.md, "Small markers").
MIN_FRAMED = 0.4


_REFINEMENT = {
    "none": cv2.aruco.CORNER_REFINE_NONE,
    "subpix": cv2.aruco.CORNER_REFINE_SUBPIX,
    "contour": cv2.aruco.CORNER_REFINE_CONTOUR,
    "apriltag": cv2.aruco.CORNER_REFINE_APRILTAG,
}


def detector_parameters(overrides: Mapping[str, Any] | None, where: Any = None) -> Any:
    """``cv2.aruco.DetectorParameters`` with sub-pixel refinement and the profile's overrides.

    ``perspectiveRemovePixelPerCell`` defaults to 8 (OpenCV: 4): reading more
    pixels per cell keeps small markers readable under noise and blur, for a
    few percent more detection time (docs/benchmarks-history.md). Keys are OpenCV's attribute
    names (``adaptiveThreshWinSizeMin``, ...); ``cornerRefinementMethod`` also
    takes ``none``, ``subpix``, ``contour`` or ``apriltag``. An unknown key or a
    value of the wrong type is a ConfigError.
    """
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    params.perspectiveRemovePixelPerCell = SMALL_MARKER_PIXELS_PER_CELL
    known = [a for a in dir(params) if not a.startswith("_") and not callable(getattr(params, a))]
    for key, value in (overrides or {}).items():
        if key not in known:
            hint = did_you_mean(str(key), known, list_up_to=0)
            raise config_error(where, "tracker.detector", f"unknown ArUco parameter {key!r}{hint}")
        if key == "cornerRefinementMethod" and isinstance(value, str):
            if value.lower() not in _REFINEMENT:
                raise config_error(
                    where,
                    "tracker.detector.cornerRefinementMethod",
                    f"one of {', '.join(_REFINEMENT)}, got {value!r}",
                )
            value = _REFINEMENT[value.lower()]
        current = getattr(params, key)
        if isinstance(current, bool) != isinstance(value, bool) or not isinstance(
            value, (int, float)
        ):
            raise config_error(
                where,
                f"tracker.detector.{key}",
                f"expected {type(current).__name__}, got {value!r}",
            )
        try:
            setattr(params, key, type(current)(value))
        except (TypeError, ValueError, cv2.error) as exc:
            raise config_error(where, f"tracker.detector.{key}", f"{exc}") from None
    return params


class ArucoTracker(Tracker):
    """ArUco (and AprilTag) markers through ``cv2.aruco.ArucoDetector``.

    ``min_side_px`` is the smallest marker side looked for, in pixels (as the
    hamming tracker's): OpenCV's ``minMarkerPerimeterRate`` is a fraction of
    the image's larger side, so it is set from this for each frame size.
    OpenCV's default (0.03, a 5 px side at 640x480) spends time on specks of
    noise too small to read; 10 px is the largest limit that still reads every
    marker the default reads (docs/benchmarks-history.md). None keeps the rate in
    ``parameters``.
    """

    family = FAMILY

    def __init__(
        self,
        dictionary: str = DEFAULT_DICTIONARY,
        parameters: Any = None,
        preprocessing: Preprocessing | None = None,
        roles: TagRoles | None = None,
        *,
        only_registered: bool = False,
        refine: str = "edges",
        min_side_px: float | None = 10.0,
        rescue: bool = True,
        where: Any = None,
    ) -> None:
        self.dictionary_name = dictionary
        self.dictionary = get_dictionary(dictionary, where)
        self.marker_family = dictionary_key(dictionary)
        params = parameters if parameters is not None else detector_parameters(None)
        self.preprocessing = preprocessing or Preprocessing()
        self.roles = roles or TagRoles({})
        self.only_registered = only_registered
        if refine not in ("edges", "opencv"):
            raise config_error(where, "tracker.refine", f"edges or opencv, got {refine!r}")
        self._edges = refine == "edges"
        if self._edges:
            params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE
        self._cells = self.dictionary.markerSize + 2
        # small markers OpenCV rejected, read again on edge-refined corners
        self._rescue = Rescuer(self.dictionary) if rescue and self._edges else None
        self._reader = self._rescue or Rescuer(self.dictionary)
        # Refine on the grey image ourselves when the detector sees a binarised one.
        self._refine_on_gray = (
            not self.preprocessing.identity
            and params.cornerRefinementMethod == cv2.aruco.CORNER_REFINE_SUBPIX
        )
        if self._refine_on_gray:
            self._win = int(params.cornerRefinementWinSize)
            self._criteria = (
                cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER,
                int(params.cornerRefinementMaxIterations),
                float(params.cornerRefinementMinAccuracy),
            )
            params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE
        self.parameters = params
        if min_side_px is not None and not min_side_px > 0:
            raise config_error(
                where, "tracker.min_side_px", f"a positive number of pixels, got {min_side_px}"
            )
        self.min_side_px = min_side_px
        self._sized_for: tuple[int, ...] = ()
        # the last detect()'s grey image and markers, for the unread count asked after it
        self._last: tuple[np.ndarray, np.ndarray] | None = None
        self._unread: int | None = 0
        self.detector = cv2.aruco.ArucoDetector(self.dictionary, params)

    @property
    def unread(self) -> int:
        """Marker-like shapes in the last detect()'s frame that read as no marker of the
        dictionary (see :class:`armtree.api.rig.Tracker`).

        Counted when first asked, from dark quadrilaterals of the frame thresholded at
        Otsu's level (OpenCV's detector drops a candidate inside a larger one, such as a
        marker inside the outline of the paper it is printed on): a search over many
        frames asks only of frames that did not show what it looked for.
        """
        if self._unread is None and self._last is not None:
            image, found = self._last
            grey = to_gray(image) if image.ndim == 3 else image
            dark = threshold_image(grey, 0, cv2.THRESH_BINARY_INV | cv2.THRESH_OTSU)
            quads = dark_quads(dark, self.min_side_px or 10.0)
            quads = quads[apart_from(quads, found)]
            self._unread = int(self._reader.marker_like(grey, quads).sum())
        return self._unread or 0

    @unread.setter
    def unread(self, count: int) -> None:
        """Tracker's own attribute, settable as there; the next detect() counts afresh."""
        self._unread = count

    def _size_for(self, shape: tuple[int, ...]) -> None:
        """Set the detector's perimeter limit from ``min_side_px`` for frames of ``shape``."""
        if self.min_side_px is None or shape[:2] == self._sized_for:
            return
        self._sized_for = shape[:2]
        self.parameters.minMarkerPerimeterRate = 4.0 * self.min_side_px / max(shape[:2])
        self.detector.setDetectorParameters(self.parameters)

    def start(self) -> None:
        """Detect once in a made-up frame, so the first real frame costs what later ones do."""

        warm_up(self, FAMILY, self.dictionary_name)

    def detect(self, frame: Frame) -> list[Detection]:
        """Every marker of the dictionary in ``frame``; poses when size and intrinsics are known.

        Sets :attr:`unread` (see :class:`armtree.api.rig.Tracker`).
        """
        image = frame.image
        colour = (
            self.preprocessing.identity
            and not self._refine_on_gray
            and isinstance(image, np.ndarray)
            and image.dtype == np.uint8
            and image.ndim == 3
            and image.shape[2] == 3
        )
        # A BGR frame goes to the detector as it is (OpenCV converts it on its worker
        # threads) and the edges are sampled from it as grey: no grey copy of the frame.
        gray = image if colour else to_gray(image)
        found_in = gray if self.preprocessing.identity else self.preprocessing.apply(gray)
        self._size_for(found_in.shape)
        corners, ids, rejected = self.detector.detectMarkers(found_in)
        quads: np.ndarray = np.asarray(corners, dtype=np.float32).reshape(-1, 4, 2)
        ids = np.zeros(0, dtype=int) if ids is None else ids.reshape(-1)
        if self._rescue is not None and rejected is not None and len(rejected):
            more, more_ids = self._rescue(
                gray, np.asarray(rejected).reshape(-1, 4, 2), quads, self.min_side_px or 4.0
            )
            quads = np.concatenate([quads, more])
            ids = np.concatenate([ids, more_ids])
        self._last, self._unread = (gray, quads), None
        if len(ids) == 0:
            return []
        detections = []
        registered = self.roles.ids
        if self._edges:
            quads = refine_corners(gray, quads, self._cells, contour_inset=0.5)
        # a marker lies in a light quiet zone; OpenCV also reads a light blob on a
        # dark patch of the scene as one, with corrections
        framed = framed_by_light(gray, quads, self._cells) >= MIN_FRAMED
        quads, ids = quads[framed], ids[framed]
        for c, marker_id in zip(quads, ids, strict=True):
            if self.only_registered and int(marker_id) not in registered:
                continue
            if self._refine_on_gray:
                c = cv2.cornerSubPix(
                    gray, c.reshape(-1, 1, 2), (self._win, self._win), (-1, -1), self._criteria
                ).reshape(4, 2)
            det = Detection(id=int(marker_id), corners=c, family=self.family)
            detections.append(finish_detection(det, self.roles, frame, pose_quality=True))
        return detections


def _tracker(values: dict[str, Any], dictionary: str, where: Any, family: str) -> ArucoTracker:
    """The tracker a checked ``tracker:`` section describes (``where`` is the profile)."""
    tracker = ArucoTracker(
        dictionary,
        detector_parameters(values["detector"], where),
        Preprocessing.from_config(values["preprocess"], where),
        TagRoles.from_profile(where, values["size_mm"], dictionary_key(dictionary)),
        only_registered=values["only_registered"],
        refine=values["refine"],
        rescue=values["rescue"],
        # an explicit detector.minMarkerPerimeterRate wins over min_side_px
        min_side_px=None
        if "minMarkerPerimeterRate" in (values["detector"] or {})
        else values["min_side_px"],
        where=where,
    )
    tracker.family = family
    return tracker


def aruco_factory(config: dict[str, Any], context: RigContext) -> ArucoTracker:
    """OpenCV ArUco markers of a predefined dictionary (4x4_50 by default), sub-pixel corners."""
    values = check_config(config, _ARUCO_PARAMS, "tracker", context.profile)
    return _tracker(values, values["dictionary"], context.profile, FAMILY)


def _validate(config: dict[str, Any], profile: Profile) -> None:
    """Load-time checks (``armtree check``): build the tracker and let OpenCV run it once."""
    values = check_config(config, _ARUCO_PARAMS, "tracker", profile)
    probe(_tracker(values, values["dictionary"], profile, FAMILY), profile, "tracker.detector")


# mypy types a def as a plain callable, which has no attributes to set: the same function,
# typed as what it is once its members are set.
aruco_factory = cast(CheckedFactory[ArucoTracker], aruco_factory)
aruco_factory.validate = _validate
# a module constant too: in the factory's body mypy still sees the def, without PARAMS
_ARUCO_PARAMS: tuple[Param, ...] = (
    Param(
        "dictionary", "str", DEFAULT_DICTIONARY, doc="4x4_50, 5x5_100, 6x6_250, apriltag_36h11, ..."
    ),
    Param("detector", "dict", {}, doc="cv2.aruco.DetectorParameters overrides by attribute name"),
    Param("preprocess", "dict", {}, doc="threshold, adaptive, block_px, offset, blur"),
    Param(
        "size_mm",
        "float",
        None,
        unit="mm",
        doc="side of markers not listed in tags:",
        exclusive_minimum=0.0,
        maximum=10000.0,
    ),
    Param("only_registered", "bool", False, doc="report only ids listed in the profile's tags:"),
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
        "refine",
        "str",
        "edges",
        doc="corner refinement: edges (fit) or opencv",
        choices=("edges", "opencv"),
    ),
    Param(
        "rescue",
        "bool",
        True,
        doc="read small candidates OpenCV rejected again on edge-refined corners (edges only)",
    ),
)
aruco_factory.PARAMS = _ARUCO_PARAMS


def apriltag_factory(config: dict[str, Any], context: RigContext) -> ArucoTracker:
    """AprilTag markers (36h11 by default): the aruco tracker with OpenCV's AprilTag dictionary."""
    values = check_config(config, _APRILTAG_PARAMS, "tracker", context.profile)
    dictionary = _apriltag_dictionary(values["family"])
    return _tracker(values, dictionary, context.profile, APRILTAG)


def _validate_apriltag(config: dict[str, Any], profile: Profile) -> None:
    """Load-time checks, as the aruco tracker's."""
    values = check_config(config, _APRILTAG_PARAMS, "tracker", profile)
    tracker = _tracker(values, _apriltag_dictionary(values["family"]), profile, APRILTAG)
    probe(tracker, profile, "tracker.detector")


def _apriltag_dictionary(family: str) -> str:
    return f"apriltag_{family}"


apriltag_factory = cast(CheckedFactory[ArucoTracker], apriltag_factory)
apriltag_factory.validate = _validate_apriltag
_APRILTAG_PARAMS: tuple[Param, ...] = (
    Param(
        "family",
        "str",
        DEFAULT_APRILTAG,
        doc="AprilTag family (OpenCV carries 16h5, 25h9, 36h10, 36h11)",
        choices=APRILTAG_FAMILIES,
    ),
    *(p for p in _ARUCO_PARAMS if p.name != "dictionary"),
)
apriltag_factory.PARAMS = _APRILTAG_PARAMS
