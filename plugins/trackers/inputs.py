"""Reading the images, videos and intrinsics the vision commands are given.

Everything a user can get wrong here (a missing, empty, unreadable or
non-image file, a malformed intrinsics option) is a :class:`ConfigError`
naming the file or option, which the CLI prints and exits 2 on.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from armtree.api.imaging import Intrinsics, distortion_from, load_calibration
from armtree.config.resolve import path_kind
from armtree.errors import ConfigError

VIDEO_SUFFIXES = (".avi", ".mp4", ".mkv", ".mov", ".webm", ".mpg", ".mpeg", ".m4v", ".wmv")


#: The most pixels an image may have (50 MP: a 8660 x 5773 photo; 20000 x 20000 would
#: take gigabytes to decode). Read from the file's header before decoding.
MAX_IMAGE_PIXELS = 50_000_000


def header_size(path: Path) -> tuple[int, int] | None:
    """(width, height) from an image file's header, decoding no pixels; None when Pillow
    does not know the format (OpenCV may still read it). A header past Pillow's own bomb
    limit (far over :data:`MAX_IMAGE_PIXELS`) is a ConfigError naming the file."""
    import warnings

    from PIL import Image

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)
        try:
            with Image.open(path) as image:
                return image.size
        except Image.DecompressionBombError:
            raise ConfigError(
                f"this image is over {2 * (Image.MAX_IMAGE_PIXELS or 0) / 1e6:.0f} MP by its "
                f"header, over the limit of {MAX_IMAGE_PIXELS // 1_000_000} MP; give a "
                "smaller one",
                file=str(path),
            ) from None
        except Exception:  # noqa: BLE001 - not an image Pillow knows: OpenCV decides
            return None


def check_pixels(width: float, height: float, where: str, what: str = "the image") -> None:
    """ConfigError at ``where`` when ``width`` x ``height`` is over :data:`MAX_IMAGE_PIXELS`."""
    if width * height > MAX_IMAGE_PIXELS:
        raise ConfigError(
            f"{what} would be {width:.0f} x {height:.0f} px ({width * height / 1e6:.3g} MP), "
            f"over the limit of {MAX_IMAGE_PIXELS // 1_000_000} MP; give a smaller one",
            file=where,
        )


def read_image(path: str | Path) -> np.ndarray:
    """An image file as BGR uint8; ConfigError naming it when it is missing, empty, no regular
    file (a folder, a FIFO, a device), over :data:`MAX_IMAGE_PIXELS` or not an image."""
    path = Path(path)
    kind = path_kind(path)
    if kind == "nothing":
        raise ConfigError("no such image file", file=str(path))
    if kind != "a file":
        raise ConfigError(f"{kind}, not an image file", file=str(path))
    if path.stat().st_size == 0:
        raise ConfigError("empty file, not an image", file=str(path))
    size = header_size(path)
    if size is not None:
        check_pixels(*size, str(path), "this image")
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None or image.size == 0:
        raise ConfigError(
            "cannot read as an image (not PNG, JPEG, BMP, TIFF or another format OpenCV decodes)",
            file=str(path),
        )
    return image


def is_video(path: str | Path) -> bool:
    """True for a file name with a video suffix."""
    return Path(path).suffix.lower() in VIDEO_SUFFIXES


def video_frames(path: str | Path) -> Iterator[np.ndarray]:
    """The frames of a video file; ConfigError naming it when it cannot be opened or has none."""
    path = Path(path)
    kind = path_kind(path)
    if kind != "a file":
        what = "no such video file" if kind == "nothing" else f"{kind}, not a video file"
        raise ConfigError(what, file=str(path))
    cap = cv2.VideoCapture(str(path))
    try:
        if not cap.isOpened():
            raise ConfigError("cannot open as a video", file=str(path))
        count = 0
        while True:
            ok, image = cap.read()
            if not ok:
                break
            count += 1
            yield image
        if count == 0:
            raise ConfigError("no frames could be decoded", file=str(path))
    finally:
        cap.release()


@dataclass(frozen=True)
class Source:
    """One image to process: the file it came from, its frame number in a video, the pixels."""

    path: str
    frame: int | None
    image: np.ndarray


def sources(paths: list[str]) -> Iterator[Source]:
    """Every image of the given files, videos expanded frame by frame, in order."""
    for path in paths:
        if is_video(path):
            for n, image in enumerate(video_frames(path)):
                yield Source(path, n, image)
        else:
            yield Source(path, None, read_image(path))


def add_intrinsics_options(parser: argparse.ArgumentParser) -> None:
    """``--calibration FILE`` or ``--intrinsics FX,FY,CX,CY [--distortion K1,K2,P1,P2,K3]``."""
    group = parser.add_argument_group("camera intrinsics (for poses)")
    group.add_argument("--calibration", metavar="FILE", help="YAML from 'armtree calibrate camera'")
    group.add_argument("--intrinsics", metavar="FX,FY,CX,CY", help="pinhole intrinsics in pixels")
    group.add_argument(
        "--distortion", metavar="K1,K2,P1,P2,K3", help="OpenCV distortion coefficients"
    )


def numbers(text: str, option: str, count: int | None = None) -> list[float]:
    """Comma-separated numbers of an option; ConfigError naming it otherwise."""
    try:
        values = [float(v) for v in text.replace(" ", "").split(",") if v != ""]
    except ValueError:
        raise ConfigError(f"{option} {text!r}: give comma-separated numbers") from None
    if count is not None and len(values) != count:
        raise ConfigError(f"{option} {text!r}: give {count} comma-separated numbers")
    if not all(np.isfinite(values)):
        raise ConfigError(f"{option} {text!r}: numbers must be finite")
    return values


def intrinsics_from_args(args: argparse.Namespace) -> Intrinsics | None:
    """The intrinsics the options give, or None (then no poses are computed)."""
    if getattr(args, "calibration", None) and getattr(args, "intrinsics", None):
        raise ConfigError("give --calibration or --intrinsics, not both")
    if getattr(args, "calibration", None):
        if not Path(args.calibration).is_file():
            raise ConfigError("no such calibration file", file=args.calibration)
        return load_calibration(args.calibration)
    if getattr(args, "intrinsics", None):
        fx, fy, cx, cy = numbers(args.intrinsics, "--intrinsics", 4)
        if not (fx > 0 and fy > 0):
            raise ConfigError(f"--intrinsics {args.intrinsics!r}: focal lengths must be positive")
        k = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])
        dist = None
        if getattr(args, "distortion", None):
            dist = numbers(args.distortion, "--distortion")
        return Intrinsics(k, distortion_from(dist, "--distortion"))
    if getattr(args, "distortion", None):
        raise ConfigError("--distortion needs --intrinsics")
    return None
