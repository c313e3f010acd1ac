"""What both trackers share: config checking, the profile's tag roles, marker pose.

Poses follow Showers 2016 ("Marker Location"): OpenCV's PnP on the four corners
of a marker whose frame is at its centre, in millimetres; here with the
square-marker solver (``SOLVEPNP_IPPE_SQUARE``). The marker frame has x to
the right and y up as printed, z out of the paper towards the viewer, so a
marker facing the camera has its z axis pointing back at it.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from armtree.api.rig import Detection, Frame, TagSpec
from armtree.config.component_config import config_error
from armtree.config.profile_access import profile_section
from armtree.loader.profile import Profile, tag_spec


def tag_table(profile: Profile, family: str | None = None) -> dict[int, TagSpec]:
    """Marker id -> its :class:`TagSpec` from the profile's ``tags:`` (empty without one),
    the ids those of marker family ``family`` where ``family_ids`` gives them.

    Uses ``profile.tags()`` when the profile offers it (a loaded profile: its ids were
    checked against their families where it was written, :mod:`.tag_checks`), else reads
    the raw ``tags:`` mapping (``{role: {id: N | ids: [...], size_mm: S}}``), where a
    size that is not a positive number, or an id given to two roles, is a ConfigError.
    """
    where = profile
    tags_method = getattr(profile, "tags", None)
    checked = callable(tags_method)
    raw = tags_method() if callable(tags_method) else profile_section(profile, "tags")
    table: dict[int, TagSpec] = {}
    for role, spec in (raw or {}).items():
        if not isinstance(spec, TagSpec):
            spec = _parse_tag(role, spec, where)
        spec = spec.in_family(family)
        if not spec.size_mm > 0:
            raise config_error(
                where, f"tags.{role}.size_mm", f"a marker size must be positive, got {spec.size_mm}"
            )
        for marker_id in spec.ids:
            if not checked and marker_id in table and table[marker_id].role != spec.role:
                raise config_error(
                    where,
                    "tags",
                    f"id {marker_id} is given to both {table[marker_id].role!r} and {spec.role!r}",
                )
            table[marker_id] = spec
    return table


def _parse_tag(role: str, spec: Any, where: Any) -> TagSpec:
    if (
        not isinstance(spec, Mapping)
        or "size_mm" not in spec
        or not ("id" in spec or "ids" in spec)
    ):
        raise config_error(where, f"tags.{role}", "give id (or ids) and size_mm")
    ids = spec["ids"] if "ids" in spec else [spec["id"]]
    if isinstance(ids, (str, bytes)) or not isinstance(ids, (list, tuple)):
        raise config_error(where, f"tags.{role}.ids", f"a list of marker ids, got {ids!r}")
    for marker_id in ids:
        if isinstance(marker_id, bool) or not isinstance(marker_id, int) or marker_id < 0:
            raise config_error(
                where, f"tags.{role}", f"marker ids are integers >= 0, got {marker_id!r}"
            )
    size = spec["size_mm"]
    if isinstance(size, bool) or not isinstance(size, (int, float)):
        raise config_error(where, f"tags.{role}.size_mm", f"a number of millimetres, got {size!r}")
    family_ids = spec.get("family_ids") or {}
    if not isinstance(family_ids, Mapping):
        raise config_error(
            where, f"tags.{role}.family_ids", f"a mapping of family: ids, got {family_ids!r}"
        )
    for family, value in family_ids.items():
        for marker_id in value if isinstance(value, (list, tuple)) else [value]:
            if isinstance(marker_id, bool) or not isinstance(marker_id, int) or marker_id < 0:
                raise config_error(
                    where,
                    f"tags.{role}.family_ids.{family}",
                    f"marker ids are integers >= 0, got {marker_id!r}",
                )
    return tag_spec(str(role), {**spec, "family_ids": family_ids})


def object_points(size_mm: float) -> np.ndarray:
    """The corners of a square marker of side ``size_mm`` in its own frame, OpenCV's order."""
    h = size_mm / 2.0
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]], dtype=np.float64)


@dataclass(frozen=True)
class MarkerPose:
    """A marker pose in the camera frame: ``rvec`` radians, ``tvec`` mm, RMS reprojection px."""

    rvec: np.ndarray
    tvec: np.ndarray
    reprojection_px: float


def solve_marker_pose(
    corners: np.ndarray, size_mm: float, camera_matrix: np.ndarray, distortion: np.ndarray | None
) -> MarkerPose | None:
    """Pose of a square marker from its four image corners (pixels, OpenCV's order).

    Uses OpenCV's PnP with ``SOLVEPNP_IPPE_SQUARE`` (Showers 2016, "Marker
    Location"), keeping the better of IPPE's two solutions; ``reprojection_px``
    is the RMS distance between the corners and their reprojections. None when
    OpenCV finds no solution.
    """
    obj = object_points(size_mm)
    img = np.asarray(corners, dtype=np.float64).reshape(4, 1, 2)
    dist = np.zeros(5) if distortion is None else np.asarray(distortion, dtype=np.float64)
    n, rvecs, tvecs, errors = cv2.solvePnPGeneric(
        obj, img, camera_matrix, dist, flags=cv2.SOLVEPNP_IPPE_SQUARE
    )
    if not n:
        return None
    # OpenCV's error is per coordinate (norm / sqrt(2N)); ours is per point, as the docstring says.
    err = float(np.ravel(errors)[0]) * np.sqrt(2.0)
    return MarkerPose(np.ravel(rvecs[0]), np.ravel(tvecs[0]), err)


class TagRoles:
    """Roles and sizes of the profile's registered markers, and the default size of others."""

    def __init__(self, table: dict[int, TagSpec], default_size_mm: float | None = None) -> None:
        self.table = table
        self.default_size_mm = default_size_mm

    @classmethod
    def from_profile(
        cls, profile: Profile, size_mm: float | None, family: str | None = None
    ) -> TagRoles:
        """The profile's ``tags:`` (their ids in marker family ``family``) with ``size_mm``
        (``tracker.size_mm``) for unlisted markers.

        Raises :class:`ConfigError` for a bad ``tags:`` entry or a size that is not positive.
        """
        return cls(tag_table(profile, family), positive_size(size_mm, "tracker.size_mm", profile))

    @property
    def ids(self) -> frozenset[int]:
        """Every registered id."""
        return frozenset(self.table)

    def describe(self, marker_id: int) -> tuple[str, float | None]:
        """``(role, size_mm)`` of a marker id: ``"unknown"`` and the default size if unregistered."""
        spec = self.table.get(marker_id)
        if spec is None:
            return "unknown", self.default_size_mm
        return spec.role, spec.size_mm


def finish_detection(
    det: Detection, roles: TagRoles, frame: Frame, pose_quality: bool
) -> Detection:
    """Fill in role, size and (when the frame has intrinsics and the size is known) the pose.

    With ``pose_quality`` the detection's quality becomes the pose's RMS
    reprojection error in pixels (the aruco convention).
    """
    det.role, det.size_mm = roles.describe(det.id)
    if det.size_mm is not None and frame.camera_matrix is not None:
        pose = solve_marker_pose(det.corners, det.size_mm, frame.camera_matrix, frame.distortion)
        if pose is not None:
            det.rvec, det.tvec = pose.rvec, pose.tvec
            if pose_quality:
                det.quality = pose.reprojection_px
    return det


def positive_size(value: float | None, name: str, where: Any = None) -> float | None:
    """``value`` unless it is given and not a positive number of mm (ConfigError)."""
    if value is not None and not value > 0:
        raise config_error(
            where, f"{name}", f"a marker size must be positive millimetres, got {value}"
        )
    return value


#: The condition in an OpenCV assertion message ("... Assertion failed) COND in function ...").
_ASSERTION = re.compile(r"Assertion failed\)\s*(.*?)\s+in function", re.S)


def probe(tracker: Any, where: Any, section: str = "tracker") -> None:
    """Run ``tracker`` once on a small synthetic frame, so OpenCV checks its parameters now.

    For load-time validation (``armtree check``): a value OpenCV only refuses when it
    first detects (``adaptiveThreshWinSizeMin: -5``) becomes a :class:`ConfigError`
    naming the condition it broke, instead of an OpenCV error in the middle of a run.
    """
    image = np.full((160, 160), 255, dtype=np.uint8)
    image[40:120, 40:120] = 0
    image[60:100, 60:100] = 255
    frame = Frame(
        image=image,
        timestamp=0.0,
        camera_matrix=np.array([[200.0, 0.0, 80.0], [0.0, 200.0, 80.0], [0.0, 0.0, 1.0]]),
        distortion=np.zeros(5),
    )
    try:
        tracker.detect(frame)
    except cv2.error as exc:
        found = _ASSERTION.search(str(exc))
        condition = found.group(1).replace("params.", "") if found else "its own checks"
        raise config_error(
            where, section, f"OpenCV refuses these parameters: they fail {condition}"
        ) from None
