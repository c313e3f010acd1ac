"""Synthetic camera frames of flat printed targets, with exact ground truth.

For tests and benchmarks of the trackers and of camera calibration: a flat
texture (a marker with its quiet zone, a chessboard) is placed at a pose in
front of a pinhole camera and drawn by its plane homography, supersampled and
averaged down so edges are anti-aliased the way a real sensor integrates
them. Ground-truth corners come from ``cv2.projectPoints`` of the same
pose. Image coordinates follow OpenCV: pixel centres at whole numbers.

Effects imitate the conditions of Showers 2016's detection-rate trials: sensor
noise, defocus blur, uneven light and a moving shadow.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import cv2
import numpy as np

from .common import object_points


def look_at_pose(
    distance_mm: float, tilt_deg: float = 0.0, spin_deg: float = 0.0, offset_mm=(0.0, 0.0)
) -> tuple[np.ndarray, np.ndarray]:
    """``(rvec, tvec)`` of a target facing the camera ``distance_mm`` away.

    ``tilt_deg`` turns it about its x axis, ``spin_deg`` about its normal;
    ``offset_mm`` moves it across the image (camera x right, y down).
    """
    # Facing the camera: target z towards the camera, target y up = camera -y.
    facing = np.array([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]])
    t, s = np.radians(tilt_deg), np.radians(spin_deg)
    tilt = np.array([[1, 0, 0], [0, np.cos(t), -np.sin(t)], [0, np.sin(t), np.cos(t)]])
    spin = np.array([[np.cos(s), -np.sin(s), 0], [np.sin(s), np.cos(s), 0], [0, 0, 1]])
    rotation = facing @ tilt @ spin
    rvec, _ = cv2.Rodrigues(rotation)
    return rvec.reshape(3), np.array([offset_mm[0], offset_mm[1], distance_mm], dtype=float)


def texture_homography(shape: tuple[int, int], width_mm: float, height_mm: float) -> np.ndarray:
    """Texture pixel index -> target-plane millimetres (centre origin, y up)."""
    h, w = shape
    sx, sy = width_mm / w, height_mm / h
    return np.array(
        [[sx, 0.0, 0.5 * sx - width_mm / 2], [0.0, -sy, height_mm / 2 - 0.5 * sy], [0.0, 0.0, 1.0]]
    )


def draw_plane(
    image: np.ndarray,
    texture: np.ndarray,
    width_mm: float,
    height_mm: float,
    camera_matrix: np.ndarray,
    rvec: np.ndarray,
    tvec: np.ndarray,
    supersample: int = 4,
) -> np.ndarray:
    """``image`` (grey float32, modified and returned) with ``texture`` drawn on the plane.

    The texture spans ``width_mm`` x ``height_mm`` centred on the target
    origin. Distortion is not modelled: give the undistorted camera matrix.
    """
    s = int(supersample)
    h, w = image.shape
    k_s = np.array(
        [
            [s * camera_matrix[0, 0], 0, s * camera_matrix[0, 2] + (s - 1) / 2],
            [0, s * camera_matrix[1, 1], s * camera_matrix[1, 2] + (s - 1) / 2],
            [0, 0, 1],
        ]
    )
    rotation, _ = cv2.Rodrigues(np.asarray(rvec, dtype=float))
    plane = np.column_stack([rotation[:, 0], rotation[:, 1], np.asarray(tvec, dtype=float)])
    homography = k_s @ plane @ texture_homography(texture.shape[:2], width_mm, height_mm)
    size = (w * s, h * s)
    tex = texture.astype(np.float32)
    warped = cv2.warpPerspective(tex, homography, size, flags=cv2.INTER_LINEAR)
    mask = cv2.warpPerspective(np.ones_like(tex), homography, size, flags=cv2.INTER_LINEAR)
    warped = cv2.resize(warped, (w, h), interpolation=cv2.INTER_AREA)
    mask = cv2.resize(mask, (w, h), interpolation=cv2.INTER_AREA)
    image *= 1.0 - mask
    image += warped
    return image


def project_corners(
    size_mm: float, camera_matrix: np.ndarray, rvec: np.ndarray, tvec: np.ndarray
) -> np.ndarray:
    """The image corners ``(4, 2)`` of a square marker of side ``size_mm`` at a pose."""
    pts, _ = cv2.projectPoints(object_points(size_mm), rvec, tvec, camera_matrix, np.zeros(5))
    return pts.reshape(4, 2)


@dataclass
class Effects:
    """Imperfections added to a rendered frame.

    ``noise`` is the grey-level standard deviation, ``blur`` the Gaussian sigma
    in pixels, ``light`` the darkest fraction of full light across the frame
    (1 for even light), ``shadow`` the light left under a shadow band (1 for
    none) whose left edge is at ``shadow_x`` (fraction of the width).
    """

    noise: float = 0.0
    blur: float = 0.0
    light: float = 1.0
    light_angle_deg: float = 30.0
    shadow: float = 1.0
    shadow_x: float = 0.5
    shadow_width: float = 0.3
    seed: int | None = None
    rng: np.random.Generator = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)

    def apply(self, image: np.ndarray) -> np.ndarray:
        """The frame as uint8 after light, shadow, blur and noise."""
        h, w = image.shape
        out = image.astype(np.float32)
        if self.light < 1.0:
            a = np.radians(self.light_angle_deg)
            yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
            ramp = (np.cos(a) * xx / w + np.sin(a) * yy / h) / (abs(np.cos(a)) + abs(np.sin(a)))
            ramp = (ramp - ramp.min()) / max(float(np.ptp(ramp)), 1e-9)
            out *= self.light + (1.0 - self.light) * ramp
        if self.shadow < 1.0:
            x0 = int(self.shadow_x * w)
            x1 = int((self.shadow_x + self.shadow_width) * w)
            band = np.ones(w, np.float32)
            band[max(x0, 0) : max(min(x1, w), 0)] = self.shadow
            soft = cv2.GaussianBlur(band.reshape(1, -1), (0, 0), 4.0).reshape(-1)
            out *= soft[None, :]
        if self.blur > 0:
            out = np.asarray(cv2.GaussianBlur(out, (0, 0), self.blur), dtype=np.float32)
        if self.noise > 0:
            out += self.rng.normal(0.0, self.noise, out.shape).astype(np.float32)
        return np.clip(out + 0.5, 0, 255).astype(np.uint8)


def nominal_camera(width: int = 640, height: int = 480, fx: float = 810.0) -> np.ndarray:
    """A pinhole camera matrix like Showers 2016's C270 (fx 810 px at 640x480)."""
    return np.array([[fx, 0, (width - 1) / 2], [0, fx, (height - 1) / 2], [0, 0, 1.0]])


def blank(width: int = 640, height: int = 480, level: float = 200.0) -> np.ndarray:
    """A uniform grey float32 background."""
    return np.full((height, width), level, np.float32)


def cluttered(width: int = 640, height: int = 480, seed: int = 0, shapes: int = 25) -> np.ndarray:
    """A desk-like grey float32 background: shading, wood-like texture and dark and light shapes.

    Gives a detector the many edges and contours a real scene has.
    """
    rng = np.random.default_rng(seed)
    shade = cv2.resize(
        rng.uniform(-40, 40, (4, 5)).astype(np.float32),
        (width, height),
        interpolation=cv2.INTER_CUBIC,
    )
    grain = cv2.resize(
        rng.uniform(-18, 18, (height // 8, width // 8)).astype(np.float32),
        (width, height),
        interpolation=cv2.INTER_LINEAR,
    )
    image = 150.0 + shade + grain
    for _ in range(shapes):
        level = float(rng.choice([rng.uniform(20, 70), rng.uniform(190, 250)]))
        x, y = int(rng.integers(0, width)), int(rng.integers(0, height))
        a, b = int(rng.integers(8, 60)), int(rng.integers(4, 40))
        if rng.random() < 0.5:
            cv2.rectangle(image, (x, y), (x + a, y + b), level, -1)
        else:
            cv2.ellipse(image, (x, y), (a, b), float(rng.uniform(0, 180)), 0, 360, level, -1)
    return image.astype(np.float32)


@dataclass(frozen=True)
class Placement:
    """One marker in a synthetic scene: id, side (mm, black square) and pose in the camera frame."""

    marker_id: int
    size_mm: float
    rvec: np.ndarray
    tvec: np.ndarray


def render_markers(
    family: str,
    placements: list[Placement],
    camera_matrix: np.ndarray,
    width: int = 640,
    height: int = 480,
    effects: Effects | None = None,
    dictionary: str = "4x4_50",
    background: float = 120.0,
    black: float = 30.0,
    white: float = 220.0,
    texture_px: int = 180,
    square: Callable[[int, int], np.ndarray] | None = None,
    backdrop: np.ndarray | None = None,
) -> tuple[np.ndarray, dict[int, np.ndarray]]:
    """A grey uint8 frame of printed markers, and their true corners ``{id: (4, 2)}``.

    Each marker is drawn with a quiet zone of 1.5 cells on ``background``;
    ``black`` and ``white`` are the grey levels of the print in full light.
    ``square(marker_id, side_px)`` replaces the built-in generator (grey
    uint8 black square, no quiet zone), e.g. to draw another library's code words.
    ``backdrop`` (float32, e.g. :func:`cluttered`) replaces the uniform background.
    """
    from .markers import cells_per_side, marker_image

    image = (
        blank(width, height, background) if backdrop is None else backdrop.astype(np.float32).copy()
    )
    truth: dict[int, np.ndarray] = {}
    cells = cells_per_side(family, dictionary)
    for p in placements:
        side_px = texture_px - texture_px % cells
        if square is None:
            tex = marker_image(family, p.marker_id, side_px, dictionary, quiet_cells=1.5)
        else:
            quiet = int(round(1.5 * side_px / cells))
            tex = cv2.copyMakeBorder(
                square(p.marker_id, side_px),
                quiet,
                quiet,
                quiet,
                quiet,
                cv2.BORDER_CONSTANT,
                value=255,
            )
        tex = tex.astype(np.float32) * ((white - black) / 255.0) + black
        full_mm = p.size_mm * tex.shape[0] / side_px
        draw_plane(image, tex, full_mm, full_mm, camera_matrix, p.rvec, p.tvec)
        truth[p.marker_id] = project_corners(p.size_mm, camera_matrix, p.rvec, p.tvec)
    return (effects or Effects()).apply(image), truth


def board_views(
    board_image: np.ndarray,
    width_mm: float,
    height_mm: float,
    camera_matrix: np.ndarray,
    count: int,
    seed: int = 0,
    margin_px: int = 40,
    size: tuple[int, int] = (640, 480),
) -> list[np.ndarray]:
    """``count`` grey uint8 views of a printed board at random distances and angles.

    The board (``width_mm`` x ``height_mm`` of ``board_image``, which is
    drawn with a white margin of ``margin_px`` texture pixels) is tilted up
    to 35 degrees about both axes, 350 to 500 mm away, with mild noise.
    """
    rng = np.random.default_rng(seed)
    h, w = board_image.shape[:2]
    tex = (
        cv2.copyMakeBorder(
            board_image, margin_px, margin_px, margin_px, margin_px, cv2.BORDER_CONSTANT, value=255
        ).astype(np.float32)
        * 0.75
        + 30.0
    )
    full_w = width_mm * (w + 2 * margin_px) / w
    full_h = height_mm * (h + 2 * margin_px) / h
    views = []
    for i in range(count):
        rvec, tvec = look_at_pose(
            rng.uniform(350, 500),
            tilt_deg=rng.uniform(-35, 35),
            spin_deg=rng.uniform(-20, 20),
            offset_mm=(rng.uniform(-30, 30), rng.uniform(-20, 20)),
        )
        rotation, _ = cv2.Rodrigues(rvec)
        a = np.radians(rng.uniform(-30, 30))
        turn = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
        rvec, _ = cv2.Rodrigues(rotation @ turn)
        image = draw_plane(
            blank(size[0], size[1], 90.0), tex, full_w, full_h, camera_matrix, rvec.reshape(3), tvec
        )
        views.append(Effects(noise=1.5, seed=seed * 1000 + i).apply(image))
    return views
