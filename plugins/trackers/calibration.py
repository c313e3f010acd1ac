"""Camera calibration from chessboard or ChArUco views, with OpenCV.

Showers 2016 calibrated its C270 with the Caltech toolbox from 12 views of a
25.4 mm chessboard (closed-form start, then non-linear refinement); OpenCV's
``calibrateCamera`` does the same. Board sizes are counted in squares, as a
user counts them on the print: a chessboard of ``cols`` x ``rows`` squares
has ``(cols - 1) x (rows - 1)`` inner corners.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from armtree.api.imaging import Intrinsics
from armtree.errors import ConfigError

from .dictionaries import get_dictionary
from .preprocess import to_gray

BOARDS = ("chessboard", "charuco")


@dataclass(frozen=True)
class Board:
    """A calibration target: ``cols`` x ``rows`` squares of ``square_mm``.

    ChArUco boards also have ``marker_mm`` markers of ``dictionary``.
    """

    kind: str
    cols: int
    rows: int
    square_mm: float
    marker_mm: float | None = None
    dictionary: str = "4x4_50"

    def __post_init__(self) -> None:
        if self.kind not in BOARDS:
            raise ConfigError(f"--board: {self.kind!r} is not one of {', '.join(BOARDS)}")
        if self.cols < 3 or self.rows < 3:
            raise ConfigError(
                f"a board needs at least 3 x 3 squares, got {self.cols} x {self.rows}"
            )
        if not self.square_mm > 0:
            raise ConfigError(f"--square-mm must be positive, got {self.square_mm}")
        if self.kind == "charuco":
            if self.marker_mm is None or not 0 < self.marker_mm < self.square_mm:
                raise ConfigError(
                    f"a ChArUco board needs --marker-mm between 0 and the square size, got {self.marker_mm}"
                )
            get_dictionary(self.dictionary)

    @property
    def inner(self) -> tuple[int, int]:
        """Inner corners across and down (OpenCV's chessboard pattern size)."""
        return self.cols - 1, self.rows - 1

    def charuco(self) -> cv2.aruco.CharucoBoard:
        """OpenCV's ChArUco board for this target."""
        assert self.marker_mm is not None, "a ChArUco board's marker size is checked when made"
        return cv2.aruco.CharucoBoard(
            (self.cols, self.rows),
            self.square_mm,
            float(self.marker_mm),
            get_dictionary(self.dictionary),
        )

    def chessboard_points(self) -> np.ndarray:
        """Inner corners in the board frame (mm, z = 0), row by row as OpenCV finds them."""
        cx, cy = self.inner
        grid = np.mgrid[0:cx, 0:cy].T.reshape(-1, 2).astype(np.float32) * self.square_mm
        return np.column_stack([grid, np.zeros(len(grid), np.float32)])

    def image(self, px_per_square: int = 60) -> np.ndarray:
        """The board as printed (grey uint8), without margin."""
        if self.kind == "charuco":
            return self.charuco().generateImage(
                (self.cols * px_per_square, self.rows * px_per_square)
            )
        squares = (np.add.outer(np.arange(self.rows), np.arange(self.cols)) % 2 == 1) * np.uint8(
            255
        )
        return cv2.resize(
            squares,
            (self.cols * px_per_square, self.rows * px_per_square),
            interpolation=cv2.INTER_NEAREST,
        )


@dataclass
class View:
    """One image in which the board was found: its corners and where the fit puts them (px)."""

    name: str
    image_points: np.ndarray
    object_points: np.ndarray
    projected: np.ndarray | None = None

    @property
    def rms_px(self) -> float:
        """RMS distance between found and reprojected corners."""
        if self.projected is None:
            return float("nan")
        return float(np.sqrt(np.mean(np.sum((self.projected - self.image_points) ** 2, axis=1))))


@dataclass
class CalibrationResult:
    """Intrinsics, overall RMS reprojection error (px), the views used and those skipped."""

    intrinsics: Intrinsics
    rms_px: float
    views: list[View]
    skipped: list[str] = field(default_factory=list)
    first_image: np.ndarray | None = None


def find_board(gray: np.ndarray, board: Board) -> tuple[np.ndarray, np.ndarray] | None:
    """``(image_points (N, 2) px, object_points (N, 3) mm)`` of the board in ``gray``, or None."""
    if board.kind == "chessboard":
        flags = cv2.CALIB_CB_NORMALIZE_IMAGE
        found, corners = cv2.findChessboardCornersSB(gray, board.inner, flags=flags)
        if not found:
            return None
        return corners.reshape(-1, 2).astype(np.float32), board.chessboard_points()
    detector = cv2.aruco.CharucoDetector(board.charuco())
    corners, ids, _, _ = detector.detectBoard(gray)
    if ids is None or len(ids) < 6:
        return None
    # the stubs type the corners as ArUco's, one array per marker; a ChArUco board's are one array
    obj, img = board.charuco().matchImagePoints(corners, ids)  # type: ignore[call-overload]
    return img.reshape(-1, 2).astype(np.float32), obj.reshape(-1, 3).astype(np.float32)


def calibrate(
    images: Iterable[tuple[str, np.ndarray]],
    board: Board,
    progress: Callable[[str], None] | None = None,
) -> CalibrationResult:
    """Intrinsics and distortion (k1, k2, p1, p2, k3) from views of ``board``.

    ``images`` are ``(name, image)`` pairs of one size. Views without the
    board are skipped; fewer than three usable views is a ConfigError.
    """
    views: list[View] = []
    skipped: list[str] = []
    size: tuple[int, int] | None = None
    first: np.ndarray | None = None
    for name, image in images:
        gray = to_gray(image)
        if size is None:
            size = (gray.shape[1], gray.shape[0])
        elif (gray.shape[1], gray.shape[0]) != size:
            raise ConfigError(
                f"image is {gray.shape[1]}x{gray.shape[0]}, the others {size[0]}x{size[1]}",
                file=name,
            )
        found = find_board(gray, board)
        if progress is not None:
            progress(name)
        if found is None:
            skipped.append(name)
            continue
        if first is None:
            first = image
        views.append(View(name, *found))
    if len(views) < 3 or size is None:
        raise ConfigError(
            f"the {board.cols}x{board.rows} {board.kind} was found in {len(views)} image(s); "
            "calibration needs at least 3 views from different angles"
        )
    rms, k, dist, rvecs, tvecs = cv2.calibrateCamera(
        [v.object_points for v in views], [v.image_points for v in views], size, None, None
    )
    for view, rvec, tvec in zip(views, rvecs, tvecs, strict=True):
        projected, _ = cv2.projectPoints(view.object_points, rvec, tvec, k, dist)
        view.projected = projected.reshape(-1, 2)
    intr = Intrinsics(k, dist.reshape(-1)[:5], size[0], size[1], True)
    return CalibrationResult(intr, float(rms), views, skipped, first)


def plot_calibration(result: CalibrationResult, path: str | Path) -> None:
    """PNG: detected and reprojected corners on the first view, residual vectors, per-view RMS."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(15, 4.8))
    ax_img, ax_res, ax_bar = fig.subplots(1, 3, gridspec_kw={"width_ratios": [1.3, 1, 1]})
    first = result.views[0]
    if result.first_image is not None:
        shown = result.first_image
        if shown.ndim == 3:
            shown = cv2.cvtColor(shown, cv2.COLOR_BGR2RGB)
        ax_img.imshow(shown, cmap="gray")
    ax_img.plot(
        first.image_points[:, 0],
        first.image_points[:, 1],
        "o",
        mfc="none",
        mec="lime",
        ms=6,
        label="found",
    )
    assert first.projected is not None  # calibrate() reprojects every view it returns
    ax_img.plot(first.projected[:, 0], first.projected[:, 1], "r+", ms=6, label="reprojected")
    ax_img.set_title(f"{first.name}: corners")
    ax_img.legend(loc="lower right", fontsize=8)
    ax_img.set_axis_off()
    for view in result.views:
        assert view.projected is not None
        d = view.projected - view.image_points
        ax_res.plot(d[:, 0], d[:, 1], ".", ms=3, alpha=0.7)
    ax_res.axhline(0, color="grey", lw=0.5)
    ax_res.axvline(0, color="grey", lw=0.5)
    ax_res.set_aspect("equal", adjustable="datalim")
    ax_res.set_xlabel("x residual (px)")
    ax_res.set_ylabel("y residual (px)")
    ax_res.set_title(f"residuals, RMS {result.rms_px:.3f} px")
    names = [Path(v.name).name for v in result.views]
    ax_bar.bar(range(len(names)), [v.rms_px for v in result.views], color="tab:blue")
    ax_bar.axhline(result.rms_px, color="tab:red", ls="--", lw=1, label="overall")
    ax_bar.set_xticks(range(len(names)), names, rotation=60, ha="right", fontsize=7)
    ax_bar.set_ylabel("RMS reprojection error (px)")
    ax_bar.set_title("per image")
    ax_bar.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(str(path), dpi=110)
