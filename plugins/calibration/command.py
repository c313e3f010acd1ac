"""``armtree calibrate camera|hand-eye|correction|camera-offset|kinematics|servos``.

With ``--rig PROFILE`` (and no offline input) ``hand-eye``, ``correction``,
``camera-offset`` and ``kinematics`` run their tree (``trees/calibrate_*.yaml``):
the arm moves, the camera and the measuring device measure, the fit is written
into the calibration file ``-o FILE`` (default ``calibration.yaml``; included by
the run when it exists, so earlier calibrations apply) with a residual plot
(``--plot``, default beside it). Data that cannot calibrate ends with exit 1 and
the reason, naming the pose to fix.

``camera``: intrinsics and distortion from chessboard or ChArUco images (a
folder, a glob or files; or live frames of a profile's camera), the RMS and
per-image reprojection errors, a PNG of corners and residuals, and a YAML
file a profile's ``camera: {calibration: FILE}`` reads.

``hand-eye``: the eye-to-hand calibration of Durovic 2017 (eqs. 1-7) from three
images of a marker on the tool, at tool positions 0, 1 (moved along the base
x axis) and 2 (then moved along base y at the same height).

``kinematics``: the least-squares kinematic calibration of Showers 2016 ("Model
Validation", Fig. 6), in :mod:`.kinematics_command`.

``servos``: a bus-servo arm's homing offsets and ranges, in :mod:`.servos_command`.
"""

from __future__ import annotations

import argparse
import glob
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from armtree.api.clock import WallClock
from armtree.api.rig import Frame, RigContext
from armtree.cli.options import seed_value
from armtree.errors import ConfigError
from armtree.plugins.trackers.calibration import BOARDS, Board, calibrate, plot_calibration
from armtree.plugins.trackers.commands import registry_of
from armtree.plugins.trackers.inputs import (
    add_intrinsics_options,
    intrinsics_from_args,
    numbers,
    read_image,
)

from .kinematics_command import configure_kinematics, run_kinematics
from .servos_command import configure_servos, run_servos

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm", ".webp")


def image_files(specs: list[str]) -> list[str]:
    """Files named by folders, globs or paths, in order; ConfigError when a spec names none."""
    files: list[str] = []
    for spec in specs:
        path = Path(spec)
        if path.is_dir():
            found = sorted(str(p) for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        elif any(ch in spec for ch in "*?["):
            found = sorted(glob.glob(spec))
        else:
            found = [spec]
        if not found:
            raise ConfigError("no images here", file=spec)
        files.extend(found)
    return files


class CalibrateCommand:
    """``armtree calibrate``: camera intrinsics, eye-to-hand pose, arm kinematics (Showers 2016)."""

    help = "calibrate a camera, an eye-to-hand camera pose (Durovic 2017) or arm kinematics (Showers 2016)"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add the ``camera``, ``hand-eye`` and ``kinematics`` sub-commands."""
        kinds = parser.add_subparsers(dest="kind", metavar="KIND", required=True)
        cam = kinds.add_parser("camera", help="intrinsics and distortion from board images")
        cam.add_argument("--images", nargs="+", metavar="DIR|GLOB|FILE", help="board images")
        cam.add_argument(
            "--rig", metavar="PROFILE", help="grab live frames from this profile's camera"
        )
        cam.add_argument("--frames", type=int, default=15, help="live frames with the board to use")
        cam.add_argument("--interval", type=float, default=1.0, help="seconds between live frames")
        cam.add_argument("--board", choices=BOARDS, default="chessboard", help="board type")
        cam.add_argument("--cols", type=int, required=True, help="squares across the board")
        cam.add_argument("--rows", type=int, required=True, help="squares down the board")
        cam.add_argument("--square-mm", type=float, required=True, help="square side (mm)")
        cam.add_argument("--marker-mm", type=float, help="ChArUco marker side (mm)")
        cam.add_argument("--dictionary", default="4x4_50", help="ChArUco dictionary")
        cam.add_argument("-o", "--output", metavar="FILE.yaml", help="write the calibration here")
        cam.add_argument("--plot", metavar="FILE.png", help="corners and residuals plot")

        he = kinds.add_parser(
            "hand-eye",
            help="camera pose: --rig moves the arm (Durovic 2017's three positions or N poses); "
            "--images takes 3 views",
        )
        he.add_argument(
            "--images", nargs=3, metavar="IMAGE", help="offline: views at positions 0, 1, 2"
        )
        he.add_argument(
            "--tool-positions", nargs=3, metavar="X,Y,Z",
            help="offline: tool positions 0, 1 (moved along base x), 2 (then along base y), mm",
        )  # fmt: skip
        _tree_options(he)
        he.add_argument(
            "--method", choices=("three-positions", "n-pose"), default="n-pose",
            help="--rig: Durovic 2017's three positions, or N well-spread poses (every method)",
        )  # fmt: skip
        he.add_argument("--poses", type=int, default=15, help="--rig n-pose: poses to visit")
        he.add_argument(
            "--step-mm", type=float, default=40.0, help="--rig three-positions: move (mm)"
        )
        he.add_argument(
            "--marker-offset", default="0,0,0", metavar="X,Y,Z", help="marker in the tool frame, mm"
        )
        he.add_argument("--tracker", default="aruco", help="tracker name (default aruco)")
        he.add_argument("--dictionary", help="ArUco dictionary (aruco)")
        he.add_argument(
            "--marker-id", type=int, help="id of the tool's marker (default: the only one)"
        )
        he.add_argument("--size-mm", type=float, help="offline: marker side (mm)")
        add_intrinsics_options(he)

        cor = kinds.add_parser(
            "correction", help="Durovic 2017's linear correction (eq. 8) on a grid"
        )
        _tree_options(cor)
        cor.add_argument("--grid", type=int, default=10, help="points along each side")
        cor.add_argument(
            "--height-mm", type=float, default=60.0, help="tool height above the table"
        )
        off = kinds.add_parser(
            "camera-offset",
            help="eye-in-hand camera offset from touch tests (Showers 2016, eq. 17)",
        )
        _tree_options(off)
        off.add_argument("--tag", default="ducky", help="tag role of the still marker to look at")
        off.add_argument("--views", type=int, default=8, help="poses to look from")

        kin = configure_kinematics(kinds)
        _tree_options(kin, rig=False, output=False, seed=False)
        kin.add_argument(
            "--poses", type=int, default=27, help="--rig without --points: poses to measure"
        )
        configure_servos(kinds)

    def run(self, args: argparse.Namespace) -> int:
        """Run the chosen calibration; 0, 1 when the data cannot calibrate, ConfigError for bad input."""
        if args.kind == "camera":
            return self._camera(args)
        if args.kind == "servos":
            return run_servos(args)
        if args.kind == "hand-eye":
            if args.images is None and args.rig is not None:
                return _tree(args, "hand_eye", plan="three_positions" if args.method == "three-positions" else "spread",
                             poses=args.poses, step_mm=args.step_mm)  # fmt: skip
            if args.images is None or args.tool_positions is None or args.size_mm is None:
                raise ConfigError(
                    "hand-eye: give --rig PROFILE (the arm moves), or --images, --tool-positions "
                    "and --size-mm (three views taken already)"
                )
            return self._hand_eye(args)
        if args.kind == "correction":
            return _tree(args, "correction", grid=args.grid, height_mm=args.height_mm)
        if args.kind == "camera-offset":
            return _tree(args, "camera_offset", tag=args.tag, views=args.views)
        if args.points is None and args.simulate is None and args.rig is not None:
            return _tree(args, "kinematics", poses=args.poses)
        return run_kinematics(args)

    # -- camera --------------------------------------------------------------

    def _camera(self, args: argparse.Namespace) -> int:
        board = Board(
            args.board, args.cols, args.rows, args.square_mm, args.marker_mm, args.dictionary
        )
        if (args.images is None) == (args.rig is None):
            raise ConfigError("give --images DIR|GLOB|FILE... or --rig PROFILE (live frames)")
        if args.output and Path(args.output).suffix.lower() not in (".yaml", ".yml"):
            raise ConfigError(f"-o {args.output}: the calibration is written as .yaml")
        if args.plot and Path(args.plot).suffix.lower() != ".png":
            raise ConfigError(f"--plot {args.plot}: the plot is written as .png")
        images = (
            self._live(args) if args.rig else [(f, read_image(f)) for f in image_files(args.images)]
        )
        result = _with_progress(images, board)
        k, dist = result.intrinsics.camera_matrix, result.intrinsics.distortion
        print(
            f"{len(result.views)} of {len(images)} images used; RMS reprojection error "
            f"{result.rms_px:.3f} px"
        )
        print(f"  fx {k[0, 0]:.2f}  fy {k[1, 1]:.2f}  cx {k[0, 2]:.2f}  cy {k[1, 2]:.2f} px")
        print(f"  distortion [k1 k2 p1 p2 k3] = {np.round(dist, 5).tolist()}")
        for view in result.views:
            print(f"  {view.name}: {view.rms_px:.3f} px")
        for name in result.skipped:
            print(f"  {name}: board not found, skipped")
        if args.output:
            from armtree.api.imaging import save_calibration

            save_calibration(
                args.output,
                result.intrinsics,
                rms_px=round(result.rms_px, 4),
                per_image_rms_px={Path(v.name).name: round(v.rms_px, 4) for v in result.views},
                board={
                    "kind": board.kind,
                    "cols": board.cols,
                    "rows": board.rows,
                    "square_mm": board.square_mm,
                    **(
                        {"marker_mm": board.marker_mm, "dictionary": board.dictionary}
                        if board.kind == "charuco"
                        else {}
                    ),
                },
            )
            print(f"wrote {args.output} (use it as camera: {{calibration: {args.output}}})")
        if args.plot:
            plot_calibration(result, args.plot)
            print(f"wrote {args.plot}")
        return 0

    def _live(self, args: argparse.Namespace) -> list[tuple[str, np.ndarray]]:
        import time

        from armtree.loader.profile import load_profile
        from armtree.plugins.trackers.calibration import find_board
        from armtree.plugins.trackers.preprocess import to_gray

        board = Board(
            args.board, args.cols, args.rows, args.square_mm, args.marker_mm, args.dictionary
        )
        profile = load_profile(args.rig)
        section = profile.section("camera")
        if not section or "type" not in section:
            raise ConfigError(f"profile {args.rig} has no camera")
        factory = registry_of(args).get("camera", section["type"]).factory
        camera = factory(dict(section), RigContext(profile=profile, clock=WallClock()))
        camera.start()
        images: list[tuple[str, np.ndarray]] = []
        last = -float("inf")
        try:
            print(f"move the board around in front of the camera; taking {args.frames} views")
            while len(images) < args.frames:
                frame = camera.read()
                if frame is None and getattr(camera, "finished", False):
                    raise ConfigError(
                        f"the camera's recording ended after {len(images)} view(s) with the board"
                    )
                if frame is None or time.monotonic() - last < args.interval:
                    time.sleep(0.01)
                    continue
                if find_board(to_gray(frame.image), board) is not None:
                    images.append((f"live_{len(images):03d}", frame.image))
                    last = time.monotonic()
                    print(f"  view {len(images)}/{args.frames}")
        finally:
            camera.close()
        return images

    # -- hand-eye (Durovic 2017) -------------------------------------------------

    def _hand_eye(self, args: argparse.Namespace) -> int:
        from armtree.maths.perception.frames import eye_to_hand_from_three_positions

        intr = intrinsics_from_args(args)
        if intr is None:
            raise ConfigError("hand-eye needs the camera intrinsics: --calibration or --intrinsics")
        if not args.size_mm > 0:
            raise ConfigError(f"--size-mm {args.size_mm:g}: a marker size must be positive")
        tool = np.array([numbers(p, "--tool-positions", 3) for p in args.tool_positions])
        offset = np.array(numbers(args.marker_offset, "--marker-offset", 3))
        _check_moves(tool)
        config: dict[str, Any] = {"size_mm": args.size_mm}
        if args.dictionary:
            config["dictionary"] = args.dictionary
        tracker = (
            registry_of(args)
            .get("tracker", args.tracker)
            .factory(config, RigContext(profile=None, clock=WallClock()))
        )
        seen = []
        for n, path in enumerate(args.images):
            image = read_image(path)
            h, w = image.shape[:2]
            sized = intr.for_size(w, h)
            dets = tracker.detect(Frame(image, float(n), sized.camera_matrix, sized.distortion, n))
            if args.marker_id is not None:
                dets = [d for d in dets if d.id == args.marker_id]
            if len(dets) != 1 or dets[0].tvec is None:
                what = "marker" if args.marker_id is None else f"marker {args.marker_id}"
                raise ConfigError(
                    f"expected one {what} with a pose, found {len(dets)}"
                    + ("" if args.marker_id is not None else "; pick one with --marker-id"),
                    file=path,
                )
            seen.append(np.asarray(dets[0].tvec, dtype=float))
        camera_T_base = eye_to_hand_from_three_positions(
            seen, tool[0], offset
        )  # Durovic 2017, eqs. 1-7
        base_T_camera = np.linalg.inv(camera_T_base)
        print("camera pose in the base frame (mm), Durovic 2017 eqs. 1-7:")
        for row in base_T_camera:
            print("  " + "  ".join(f"{v:10.4f}" for v in row))
        for n, t in enumerate(seen):
            predicted = camera_T_base @ np.append(tool[n] + offset, 1.0)
            print(f"  view {n}: marker seen at {np.round(t, 1).tolist()} mm, "
                  f"predicted {np.round(predicted[:3], 1).tolist()} mm")  # fmt: skip
        if args.output:
            data = {
                "mount": "eye_to_hand",
                "extrinsics": np.round(base_T_camera, 6).tolist(),
                "camera_T_base": np.round(camera_T_base, 6).tolist(),
            }
            header = "# Eye-to-hand calibration (Durovic 2017, eqs. 1-7): camera pose in the base frame, mm\n"
            Path(args.output).write_text(header + yaml.safe_dump(data, sort_keys=False))
            print(f"wrote {args.output} (camera: {{mount: eye_to_hand, extrinsics: ...}})")
        return 0


def _tree_options(
    parser: argparse.ArgumentParser, rig: bool = True, output: bool = True, seed: bool = True
) -> None:
    """The options of a calibration that runs its tree."""
    from armtree.cli.options import add_set_option

    if rig:
        parser.add_argument(
            "--rig", metavar="PROFILE", help="run the calibration tree on this profile"
        )
    if output:
        parser.add_argument(
            "-o",
            "--output",
            metavar="FILE.yaml",
            help="the calibration file (default calibration.yaml)",
        )
        parser.add_argument(
            "--plot", metavar="FILE.png", help="the residual plot (default beside the file)"
        )
    if seed:
        parser.add_argument(
            "--seed", type=seed_value, default=0, help="the run's seed (sim noise, random poses)"
        )
    add_set_option(parser, "override a profile key for this run (repeatable)")


def _tree(args: argparse.Namespace, kind: str, **params: Any) -> int:
    """Run ``trees/calibrate_KIND.yaml`` on ``--rig``; print what it found and wrote."""
    from .run import profile_overrides, report, run_tree

    if args.rig is None:
        raise ConfigError(f"calibrate {kind.replace('_', '-')}: give --rig PROFILE")
    out = args.output or "calibration.yaml"
    if Path(out).suffix.lower() not in (".yaml", ".yml"):
        raise ConfigError(f"-o {out}: the calibration is written as .yaml")
    plot = args.plot or str(Path(out).with_name(f"{Path(out).stem}_{kind}.png"))
    if Path(plot).suffix.lower() != ".png":
        raise ConfigError(f"--plot {plot}: the plot is written as .png")
    values = {**params, "out": out, "plot": plot}
    overrides = profile_overrides(out, args.overrides) + [f"{k}={v}" for k, v in values.items()]
    result, run = run_tree(f"calibrate_{kind}.yaml", args.rig, overrides, args.seed, f"calibrate {kind.replace('_', '-')}",
                           getattr(args, "manager", None))  # fmt: skip
    for node in run.root.iterate():
        if type(node).__name__ == "FitCalibration" and node.feedback_message:
            print(f"{kind.replace('_', '-')}: {node.feedback_message}")
    code = report(result, f"calibrate {kind.replace('_', '-')}")
    if code == 0:
        print(
            f"wrote {out} (a profile uses it with include: {out}, or --set include={out}) and {plot}"
        )
    return code


def _check_moves(tool: np.ndarray) -> None:
    """Durovic 2017's three positions: 0 -> 1 along base x, 1 -> 2 along base y at the same height."""
    a, b = tool[1] - tool[0], tool[2] - tool[1]
    if np.linalg.norm(a) < 1.0 or np.linalg.norm(b) < 1.0:
        raise ConfigError("--tool-positions: the moves 0 -> 1 and 1 -> 2 must be at least 1 mm")
    if np.degrees(np.arccos(abs(a[0]) / np.linalg.norm(a))) > 5.0:
        raise ConfigError(
            "--tool-positions: position 1 must be position 0 moved along the base x axis"
        )
    if abs(b[2]) > 2.0:
        raise ConfigError("--tool-positions: positions 1 and 2 must be at the same height (z)")


def _with_progress(images: list[tuple[str, np.ndarray]], board: Board) -> Any:
    from rich.console import Console
    from rich.progress import Progress

    with Progress(console=Console(stderr=True), transient=True) as progress:
        task = progress.add_task("finding the board", total=len(images))
        return calibrate(images, board, progress=lambda name: progress.advance(task))
