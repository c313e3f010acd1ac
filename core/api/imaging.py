"""What cameras and trackers share: camera intrinsics from a profile or a calibration file,
that file's format, and the frame rate a video file declares.

A camera section gives its intrinsics either inline (Showers 2016's C270 values)::

    camera: {type: opencv, intrinsics: {fx: 810.06, fy: 810.76, cx: 325.40, cy: 249.02},
             distortion: [0.01584, 0.37926, -0.00056, 0.00331, 0]}

or as the YAML file ``armtree calibrate camera`` writes::

    camera: {type: opencv, calibration: c270.yaml}

A relative path is looked up next to the profile, then in the working
directory. Pixels for the matrix; OpenCV's (k1, k2, p1, p2, k3) for distortion.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from armtree.config.component_config import config_error
from armtree.config.params import Param
from armtree.config.profile_access import AnyProfile, profile_source
from armtree.errors import ConfigError

#: The keys every camera type accepts for its intrinsics and mounting.
INTRINSICS_PARAMS: tuple[Param, ...] = (
    Param("intrinsics", "dict", None, unit="px", doc="{fx, fy, cx, cy}"),
    Param("distortion", "vector", None, doc="OpenCV's [k1, k2, p1, p2, k3]"),
    Param("calibration", "str", None, doc="YAML file written by 'armtree calibrate camera'"),
    Param(
        "mount",
        "str",
        "eye_to_hand",
        doc="eye_in_hand or eye_to_hand",
        choices=("eye_in_hand", "eye_to_hand"),
    ),
    Param("extrinsics", "list", None, unit="mm", doc="4x4 camera pose in the tool or base frame"),
)


@dataclass(frozen=True)
class Intrinsics:
    """A camera matrix (3x3, px) and distortion (k1, k2, p1, p2, k3) for one image size.

    ``calibrated`` is False for the nominal guess used when the profile gives
    nothing (fx = fy = image width, principal point at the centre): poses
    from such frames are only roughly scaled.
    """

    camera_matrix: np.ndarray
    distortion: np.ndarray
    width: int | None = None
    height: int | None = None
    calibrated: bool = True
    source: str | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def for_size(self, width: int, height: int) -> Intrinsics:
        """These intrinsics for frames of ``width`` x ``height`` (scaled if calibrated at another size)."""
        if (
            self.width is None
            or self.height is None
            or (self.width, self.height) == (width, height)
        ):
            return self
        sx, sy = width / self.width, height / self.height
        k = self.camera_matrix.copy()
        k[0, 0] *= sx
        k[0, 2] = (k[0, 2] + 0.5) * sx - 0.5
        k[1, 1] *= sy
        k[1, 2] = (k[1, 2] + 0.5) * sy - 0.5
        return Intrinsics(k, self.distortion, width, height, self.calibrated, self.source)


def nominal(width: int, height: int) -> Intrinsics:
    """The uncalibrated guess: fx = fy = width, principal point at the image centre."""
    k = np.array([[width, 0, (width - 1) / 2], [0, width, (height - 1) / 2], [0, 0, 1.0]])
    return Intrinsics(k, np.zeros(5), width, height, calibrated=False)


def matrix_from(values: Mapping[str, Any], path: str, where: Any = None) -> np.ndarray:
    """A 3x3 camera matrix from ``{fx, fy, cx, cy}`` (pixels); ConfigError names what is wrong."""
    missing = [k for k in ("fx", "fy", "cx", "cy") if k not in values]
    if missing:
        raise config_error(where, path, f"missing {', '.join(missing)} (pixels)")
    try:
        fx, fy, cx, cy = (float(values[k]) for k in ("fx", "fy", "cx", "cy"))
    except (TypeError, ValueError):
        raise config_error(where, path, "fx, fy, cx and cy are numbers of pixels") from None
    if not (fx > 0 and fy > 0):
        raise config_error(where, path, f"focal lengths must be positive, got fx={fx}, fy={fy}")
    return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def distortion_from(values: Any, path: str, where: Any = None) -> np.ndarray:
    """OpenCV distortion coefficients (4, 5, 8, 12 or 14 numbers) as a float array."""
    if values is None:
        return np.zeros(5)
    try:
        arr = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise config_error(where, path, "a list of numbers [k1, k2, p1, p2, k3]") from None
    if arr.size not in (4, 5, 8, 12, 14) or not np.all(np.isfinite(arr)):
        raise config_error(
            where, path, f"OpenCV takes 4, 5, 8, 12 or 14 finite coefficients, got {values!r}"
        )
    return arr


def load_calibration(path: str | Path) -> Intrinsics:
    """Read a calibration YAML (``armtree calibrate camera``'s output); ConfigError names the file."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise ConfigError(
            f"cannot read calibration file: {exc.strerror or exc}", file=str(path)
        ) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise ConfigError(
            f"not valid YAML: {getattr(exc, 'problem', exc)}",
            file=str(path),
            line=mark.line + 1 if mark else None,
            column=mark.column + 1 if mark else None,
        ) from None
    if not isinstance(data, Mapping) or "intrinsics" not in data:
        raise ConfigError("a calibration file needs intrinsics: {fx, fy, cx, cy}", file=str(path))
    k = matrix_from(data["intrinsics"], "intrinsics", str(path))
    dist = distortion_from(data.get("distortion"), "distortion", str(path))
    width, height = data.get("width"), data.get("height")
    extra = {
        key: v
        for key, v in data.items()
        if key not in ("intrinsics", "distortion", "width", "height")
    }
    return Intrinsics(
        k,
        dist,
        int(width) if width else None,
        int(height) if height else None,
        True,
        str(path),
        extra,
    )


def save_calibration(path: str | Path, intrinsics: Intrinsics, **extra: Any) -> None:
    """Write intrinsics as a YAML file a profile's ``calibration:`` (or its keys) can use."""
    k = intrinsics.camera_matrix
    data: dict[str, Any] = {
        "intrinsics": {
            "fx": round(float(k[0, 0]), 4),
            "fy": round(float(k[1, 1]), 4),
            "cx": round(float(k[0, 2]), 4),
            "cy": round(float(k[1, 2]), 4),
        },
        "distortion": [round(float(v), 6) for v in intrinsics.distortion.reshape(-1)],
    }
    if intrinsics.width:
        data["width"] = int(intrinsics.width)
        data["height"] = int(intrinsics.height or 0)
    data.update(extra)
    header = (
        "# Camera calibration written by 'armtree calibrate camera' (pixels; OpenCV distortion)\n"
    )
    Path(path).write_text(header + yaml.safe_dump(data, sort_keys=False))


def intrinsics_from_config(
    config: Mapping[str, Any], profile: AnyProfile | None
) -> Intrinsics | None:
    """The intrinsics a camera section gives (a calibration file or inline values), or None."""
    calibration = config.get("calibration")
    source = profile_source(profile)
    if calibration:
        path = Path(calibration)
        if not path.is_absolute():
            beside = Path(source).parent / path if source else None
            path = beside if beside is not None and beside.exists() else Path.cwd() / path
        if not path.exists():
            raise config_error(profile, "camera.calibration", f"no file {calibration}")
        return load_calibration(path)
    if config.get("intrinsics") is not None:
        k = matrix_from(config["intrinsics"], "camera.intrinsics", profile)
        dist = distortion_from(config.get("distortion"), "camera.distortion", profile)
        return Intrinsics(k, dist, None, None, True, source)
    return None


class IntrinsicsBySize:
    """The intrinsics for each frame size a camera delivers (scaled, or nominal when none given)."""

    def __init__(self, base: Intrinsics | None) -> None:
        self.base = base
        self._cache: dict[tuple[int, int], Intrinsics] = {}

    def get(self, width: int, height: int) -> Intrinsics:
        """Intrinsics for ``width`` x ``height`` frames."""
        key = (width, height)
        if key not in self._cache:
            self._cache[key] = (
                nominal(width, height) if self.base is None else self.base.for_size(width, height)
            )
        return self._cache[key]


def extrinsics_from(value: Any, where: Any = None) -> np.ndarray:
    """A 4x4 pose (mm) from a nested list, identity when absent."""
    if value is None:
        return np.eye(4)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        arr = np.zeros(0)
    if arr.shape != (4, 4) or not np.all(np.isfinite(arr)):
        raise config_error(
            where, "camera.extrinsics", f"a 4x4 matrix of numbers (mm), got {value!r}"
        )
    return arr


def video_fps(path: Path) -> float | None:
    """The frame rate a video file declares, or None."""
    cap = cv2.VideoCapture(str(path))
    try:
        fps = cap.get(cv2.CAP_PROP_FPS) if cap.isOpened() else 0.0
    finally:
        cap.release()
    return float(fps) if fps and np.isfinite(fps) and fps > 0 else None
