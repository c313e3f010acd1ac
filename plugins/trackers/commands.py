"""``armtree detect`` and ``armtree markers``.

``detect`` runs any registered tracker on images or videos and prints what
it found (``--json``: one JSON record per image), draws it (``--annotate``),
or measures the marker detection rate of Showers 2016 eq. 15 (``--rate``).
``markers`` writes printable markers, one per PNG or a sheet of many on A4.
Bad input raises :class:`ConfigError` naming the file or option (exit 2).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from armtree.api.clock import WallClock
from armtree.api.imaging import Intrinsics, intrinsics_from_config
from armtree.api.output_paths import output_file, output_folder
from armtree.api.rig import Detection, Frame, RigContext
from armtree.errors import ConfigError
from armtree.loader.profile import Profile

from .annotate import annotate
from .detection_rate import marker_detection_rate
from .dictionaries import APRILTAG_FAMILIES, get_dictionary
from .families import MarkerFamily, apriltag_dictionary, family_named
from .inputs import (
    Source,
    add_intrinsics_options,
    check_pixels,
    intrinsics_from_args,
    is_video,
    sources,
)
from .markers import (
    A4_MM,
    MM_PER_INCH,
    cells_per_side,
    printable_marker,
    write_png,
    write_sheet,
)


def registry_of(args: argparse.Namespace) -> Any:
    """The plugin registry the CLI built (or the process's shared one)."""
    manager = getattr(args, "manager", None)
    if manager is None:
        from armtree.hooks.plugin_manager import get_plugin_manager

        manager = get_plugin_manager()
    return manager.registry


def detection_record(det: Detection) -> dict[str, Any]:
    """A detection as plain JSON data (pixels, mm, radians)."""
    return {
        "id": int(det.id),
        "family": det.family,
        "corners": np.round(np.asarray(det.corners, dtype=float), 3).tolist(),
        "quality": round(float(det.quality), 4),
        "role": det.role,
        "size_mm": det.size_mm,
        "ambiguous": bool(det.ambiguous),
        "rvec": None if det.rvec is None else np.round(np.asarray(det.rvec, float), 5).tolist(),
        "tvec": None if det.tvec is None else np.round(np.asarray(det.tvec, float), 3).tolist(),
    }


class DetectCommand:
    """``armtree detect``: run a tracker on images or videos."""

    help = (
        "find markers in images or videos with a tracker (JSON, annotated images, detection rate)"
    )

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add detect's arguments."""
        parser.add_argument("images", nargs="+", metavar="IMAGE", help="image or video files")
        parser.add_argument("--tracker", default="aruco", help="tracker name (default aruco)")
        parser.add_argument(
            "--dictionary",
            help="ArUco dictionary (aruco; default 4x4_50) or AprilTag family (apriltag; 36h11)",
        )
        parser.add_argument("--size-mm", type=float, help="marker side for poses (mm)")
        parser.add_argument(
            "--rig", metavar="PROFILE", help="take tracker settings and tags from a profile"
        )
        parser.add_argument(
            "--threshold", type=float, help="preprocess: threshold at this fraction (0.4)"
        )
        parser.add_argument(
            "--adaptive", action="store_true", help="preprocess: adaptive threshold"
        )
        parser.add_argument("--blur", type=int, help="preprocess: Gaussian blur kernel (odd px)")
        parser.add_argument("--json", action="store_true", help="one JSON record per image")
        parser.add_argument("--annotate", metavar="OUT_DIR", help="write annotated images here")
        parser.add_argument(
            "--rate",
            action="store_true",
            help="marker detection rate (Showers 2016 eq. 15) over all frames",
        )
        parser.add_argument(
            "--fps", type=float, help="frame rate for --rate (a video's own by default)"
        )
        parser.add_argument("--marker-id", type=int, help="count only this id for --rate")
        add_intrinsics_options(parser)

    def run(self, args: argparse.Namespace) -> int:
        """Detect, print, draw; the exit code (0, or ConfigError for bad input)."""
        profile = None
        if args.rig:
            from armtree.loader.profile import load_profile

            profile = load_profile(args.rig)
        tracker = self._tracker(args, profile)
        # --intrinsics or --calibration win; else the profile's camera, so poses come out
        intr = intrinsics_from_args(args) or profile_intrinsics(profile)
        if args.rate:
            return self._rate(args, tracker, intr)
        out_dir = None if args.annotate is None else output_folder(args.annotate, "--annotate")
        for n, src in enumerate(sources(args.images)):
            frame = self._frame(src, n, intr)
            dets = _detect(tracker, frame, src.path)
            self._report(args, src, dets)
            if out_dir is not None:
                name = (
                    Path(src.path).stem
                    + ("" if src.frame is None else f"_{src.frame:05d}")
                    + ".png"
                )
                drawn = annotate(src.image, dets, frame.camera_matrix, frame.distortion)
                cv2.imwrite(str(out_dir / name), drawn)
        return 0

    def _rate(self, args: argparse.Namespace, tracker: Any, intr: Any) -> int:
        fps = self._fps(args)
        frames = (self._frame(src, n, intr) for n, src in enumerate(sources(args.images)))
        try:
            result = marker_detection_rate(tracker, frames, fps, args.marker_id)
        except ValueError as exc:
            raise ConfigError(f"cannot process the frames: {exc}") from None
        if args.json:
            record = {
                "frames": result.frames,
                "detections": result.detections,
                "fps": result.fps,
                "per_frame": round(result.per_frame, 5),
                "mdr": round(result.rate, 4),
                "marker_id": args.marker_id,
            }
            print(json.dumps(record))
        else:
            what = "any marker" if args.marker_id is None else f"marker {args.marker_id}"
            print(
                f"marker detection rate ({what}): {result.rate:.2f} markers/s "
                f"({result.detections} detections in {result.frames} frames at {result.fps:g} fps)"
            )
        return 0

    def _tracker(self, args: argparse.Namespace, profile: Profile | None) -> Any:
        registry = registry_of(args)
        config: dict[str, Any] = {}
        if profile is not None:
            section = profile.section("tracker") or {}
            if section.get("type", args.tracker) == args.tracker:
                config = {k: v for k, v in section.items() if k != "type"}
        if args.dictionary is not None:
            if args.tracker == "apriltag":
                config["family"] = apriltag_dictionary(args.dictionary).removeprefix("apriltag_")
            elif args.tracker == "aruco":
                get_dictionary(args.dictionary)
                config["dictionary"] = args.dictionary
            else:
                raise ConfigError(
                    f"--dictionary applies to the aruco and apriltag trackers, not {args.tracker!r}"
                )
        if args.size_mm is not None:
            if not 0 < args.size_mm < math.inf:
                raise ConfigError(
                    f"--size-mm {args.size_mm:g}: a marker size must be a positive, finite number of mm"
                )
            config["size_mm"] = args.size_mm
        prep = dict(config.get("preprocess") or {})
        if args.threshold is not None:
            prep["threshold"] = args.threshold
        if args.adaptive:
            prep["adaptive"] = True
        if args.blur is not None:
            prep["blur"] = args.blur
        if prep:
            config["preprocess"] = prep
        factory = registry.get("tracker", args.tracker).factory
        return factory(config, RigContext(profile=profile, clock=WallClock()))

    def _fps(self, args: argparse.Namespace) -> float:
        if args.fps is not None:
            if not 0 < args.fps < math.inf:
                raise ConfigError(f"--fps {args.fps:g}: give a positive, finite frame rate")
            return float(args.fps)
        videos = [p for p in args.images if is_video(p)]
        if videos:
            from armtree.api.imaging import video_fps

            fps = video_fps(videos[0])
            if fps:
                return fps
        raise ConfigError("--rate needs --fps (the rate the frames were taken at)")

    @staticmethod
    def _frame(src: Source, n: int, intr: Any) -> Frame:
        if intr is not None:
            h, w = src.image.shape[:2]
            intr = intr.for_size(w, h)
        return Frame(
            image=src.image,
            timestamp=float(n),
            camera_matrix=None if intr is None else intr.camera_matrix,
            distortion=None if intr is None else intr.distortion,
            index=n,
        )

    @staticmethod
    def _report(args: argparse.Namespace, src: Source, dets: list[Detection]) -> None:
        if args.json:
            record: dict[str, Any] = {"path": src.path}
            if src.frame is not None:
                record["frame"] = src.frame
            record["detections"] = [detection_record(d) for d in dets]
            print(json.dumps(record))
            return
        where = src.path if src.frame is None else f"{src.path}#{src.frame}"
        print(f"{where}: {len(dets)} marker(s)")
        for d in dets:
            centre = np.asarray(d.corners).mean(axis=0)
            line = f"  id {d.id}" + (" (ambiguous)" if d.ambiguous else "")
            line += f" {d.role} at ({centre[0]:.1f}, {centre[1]:.1f}) px"
            if d.tvec is not None:
                t = np.asarray(d.tvec, float)
                line += f", t = [{t[0]:.1f}, {t[1]:.1f}, {t[2]:.1f}] mm"
            print(line)


def profile_intrinsics(profile: Profile | None) -> Intrinsics | None:
    """The intrinsics of the profile's camera (calibration file or inline values), or None.

    They hold for the camera's ``width`` x ``height`` when it gives them, and are
    scaled to the size of each image.
    """
    camera = None if profile is None else profile.section("camera")
    if not camera:
        return None
    intr = intrinsics_from_config(camera, profile)
    if intr is not None and intr.width is None and camera.get("width") and camera.get("height"):
        intr = dataclasses.replace(intr, width=int(camera["width"]), height=int(camera["height"]))
    return intr


def _detect(tracker: Any, frame: Frame, path: str) -> list[Detection]:
    try:
        return tracker.detect(frame)
    except ValueError as exc:
        raise ConfigError(f"cannot process this image: {exc}", file=path) from None


def parse_ids(text: str) -> list[int]:
    """``"0-5,8,10"`` -> ``[0, 1, 2, 3, 4, 5, 8, 10]``; ConfigError for anything else."""
    ids: list[int] = []
    for part in text.replace(" ", "").split(","):
        if not part:
            continue
        try:
            if "-" in part[1:]:
                lo, hi = part.split("-", 1)
                a, b = int(lo), int(hi)
                if b < a:
                    raise ValueError
                ids.extend(range(a, b + 1))
            else:
                ids.append(int(part))
        except ValueError:
            raise ConfigError(f"--sheet {text!r}: give ids like 0-5,8,10") from None
    if not ids:
        raise ConfigError(f"--sheet {text!r}: no ids")
    return ids


def marker_family(family: str, dictionary: str | None) -> MarkerFamily:
    """The family ``armtree markers --family F [--dictionary D]`` names: ``hamming``,
    ``aruco`` (dictionary D, 4x4_50 by default), ``apriltag`` (family D, 36h11 by
    default) or an ArUco dictionary's own name. ConfigError naming the choices."""
    if family == "aruco":
        return family_named(dictionary or "4x4_50")
    if family == "apriltag":
        return family_named(apriltag_dictionary(dictionary or "36h11"))
    if dictionary is not None:
        raise ConfigError(f"--dictionary applies to --family aruco or apriltag, not {family!r}")
    try:
        return family_named(family)
    except ConfigError as exc:
        raise ConfigError(
            f"--family {family}: {exc.message} (or aruco --dictionary D, apriltag --dictionary "
            f"{'|'.join(APRILTAG_FAMILIES)})"
        ) from None


def check_marker_id(family: MarkerFamily, marker_id: int) -> None:
    """ConfigError unless ``marker_id`` is a valid id of ``family``, naming valid ones near it."""
    problem = family.id_error(marker_id)
    if problem is not None:
        raise ConfigError(f"--id {marker_id}: {problem}")


def _check_marker_pixels(
    args: argparse.Namespace, generator: str, dictionary: str, single: bool
) -> None:
    """ConfigError naming --dpi and --size-mm when the image would be over the pixel limit
    (checked before any is allocated: --dpi 1000000 would ask for petabytes)."""
    if single:
        cells = cells_per_side(generator, dictionary)
        side = args.size_mm * args.dpi / MM_PER_INCH * (1 + 2 / cells)
        width = height = side
        what = "the marker"
    else:
        width, height = (mm * args.dpi / MM_PER_INCH for mm in A4_MM)
        what = "an A4 page"
    check_pixels(width, height, f"--dpi {args.dpi:g} --size-mm {args.size_mm:g}", what)


class MarkersCommand:
    """``armtree markers``: printable marker PNGs, or A4 sheets (PNG or PDF)."""

    help = "write printable Hamming, ArUco or AprilTag markers (PNG with DPI, or A4 sheets)"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add markers' arguments."""
        parser.add_argument(
            "--family",
            required=True,
            metavar="FAMILY",
            help="hamming, aruco, apriltag, or an ArUco dictionary (4x4_50, apriltag_36h11, ...)",
        )
        parser.add_argument("--id", type=int, help="marker id")
        parser.add_argument("--sheet", metavar="IDS", help="several ids on A4, e.g. 0-5,8")
        parser.add_argument(
            "--size-mm", type=float, default=25.0, help="side of the black square (mm)"
        )
        parser.add_argument(
            "--dpi", type=float, default=300.0, help="print resolution (default 300)"
        )
        parser.add_argument(
            "--dictionary",
            help="ArUco dictionary (aruco; default 4x4_50) or AprilTag family (apriltag; 36h11)",
        )
        parser.add_argument(
            "-o", "--output", required=True, metavar="FILE", help=".png (or .pdf sheet)"
        )

    def run(self, args: argparse.Namespace) -> int:
        """Write the marker(s); 0, or ConfigError for bad options."""
        if not 0 < args.size_mm < math.inf:
            raise ConfigError(
                f"--size-mm {args.size_mm:g}: a marker size must be a positive, finite number of mm"
            )
        if not 0 < args.dpi < math.inf:
            raise ConfigError(f"--dpi {args.dpi:g}: give a positive, finite resolution")
        family = marker_family(args.family, args.dictionary)
        if (args.id is None) == (args.sheet is None):
            raise ConfigError("give --id N for one marker or --sheet IDS for a sheet")
        out = output_file(args.output, "-o")
        suffix = out.suffix.lower()
        if suffix not in (".png", ".pdf"):
            raise ConfigError(f"-o {args.output}: write a .png (or a .pdf sheet)")
        ids = [args.id] if args.id is not None else parse_ids(args.sheet)
        # only ids the family's tracker reads (docs/trackers.md: valid ids)
        for marker_id in ids:
            check_marker_id(family, marker_id)
        dictionary = family.dictionary or "4x4_50"
        _check_marker_pixels(args, family.generator, dictionary, single=args.sheet is None)
        if args.sheet is None and suffix == ".png":
            printed = printable_marker(
                family.generator, args.id, args.size_mm, args.dpi, dictionary
            )
            write_png(out, printed.image, args.dpi)
            print(
                f"{out}: {family.name} id {args.id}, {printed.side_px} px = "
                f"{printed.size_mm:.2f} mm at {args.dpi:g} dpi (print at 100 %)"
            )
            return 0
        try:
            pages = write_sheet(out, family.generator, ids, args.size_mm, args.dpi, dictionary)
        except ValueError as exc:
            raise ConfigError(str(exc), file=str(out)) from None
        print(
            f"{out}: {len(ids)} {family.name} marker(s) of {args.size_mm:g} mm on {pages} A4 page(s)"
        )
        return 0
