"""Small and hard markers: detection rate, wrong ids and speed per family and marker size.

Run with ``python benchmarks/bench_small_markers.py [--frames N] [--quick]``.

Frames are 640x480 grey views of a cluttered desk (shading, wood-like grain, dark
and light shapes) holding three markers of one family, drawn through a pinhole
camera like Showers 2016's C270 (fx 810 px), so the truth (ids and corners) is exact.
A frame's markers share one frontal size, 12 to 40 px a side, and one of two
conditions:

* ``noise+blur``: sensor noise (sd 2-4 grey levels), defocus blur (sd 0.5-1.0 px),
  tilt up to 30 degrees, even light;
* ``hard``: noise (sd 2-5), blur (sd 0.5-1.2 px), perspective up to 60 degrees,
  light falling to 45-80 % across the frame, a shadow band in half the frames,
  and in a third of them one marker partly covered (10-30 % of its area) by a
  dark or light shape.

Families: ArUco 4x4_50 and AprilTag 36h11 (the ``aruco`` / ``apriltag`` tracker
against OpenCV's ``ArucoDetector.detectMarkers`` with the tracker's own detector
parameters), and Hampy (the ``hamming`` tracker, with Showers 2016's threshold as it
ships and with the adaptive one, against ``hampy.detect_markers`` 1.4.2,
``pip install -e '.[bench]'``; OpenCV has no Hampy dictionary). Each
family sees the same layouts (poses, light, noise) with its own markers.

Printed: per family, condition and size, the markers found (a detection of the
right id within half a side of its centre; covered markers apart) and the wrong
ids (a detection whose id is no marker's at that place) of every contender; then
milliseconds per frame of each tracker against OpenCV's detector alone on the
same frames (for Hampy frames the detector with 4x4_50: the candidate search
every square-marker detector does), CPU | wall | CPU on one thread
(``call_timing.py``). Goals (issue 25): >= 95 % found at 16 px with noise and
blur, 0 wrong ids in 10,000 frames per family, no tracker slower than the
bare detector by more than 1.5x.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass, field

import cv2
import numpy as np
from call_timing import ratios, time_contenders
from rich.console import Console
from rich.progress import track

from armtree.api.rig import Frame
from armtree.plugins.trackers import hamming_code as hc
from armtree.plugins.trackers import synthetic as syn
from armtree.plugins.trackers.aruco import ArucoTracker
from armtree.plugins.trackers.dictionaries import get_dictionary
from armtree.plugins.trackers.hamming import HammingTracker
from armtree.plugins.trackers.markers import cells_per_side, marker_image
from armtree.plugins.trackers.preprocess import Preprocessing

K = syn.nominal_camera()
FX = K[0, 0]
W, H = 640, 480
SIZES = (12, 14, 16, 20, 24, 30, 40)
CONDITIONS = ("noise+blur", "hard")
#: Family -> (generator, dictionary).
FAMILIES = {
    "4x4_50": ("aruco", "4x4_50"),
    "apriltag_36h11": ("aruco", "apriltag_36h11"),
    "hamming": ("hamming", "4x4_50"),
}
SUPERSAMPLE = 4
console = Console(stderr=True)


def hamming_ids(count: int, seed: int = 25) -> list[int]:
    """``count`` random valid Hampy ids (docs/trackers.md)."""
    rng = np.random.default_rng(seed)
    out: list[int] = []
    while len(out) < count:
        marker_id = int(rng.integers(1, hc.MAX_ID - 1))
        if hc.is_valid_id(marker_id):
            out.append(marker_id)
    return out


ID_POOLS = {"4x4_50": list(range(50)), "apriltag_36h11": list(range(587))}


@dataclass
class Layout:
    """One frame's draw: where its three markers are, the light, blur, noise, occlusion."""

    size_px: int
    condition: str
    poses: list[tuple[np.ndarray, np.ndarray]]
    picks: list[int]  # index into the family's id pool
    backdrop: int
    light: float
    light_angle: float
    shadow: float
    shadow_x: float
    blur: float
    noise: float
    noise_seed: int
    cover: tuple[int, float, float, float, float] | None  # marker, u, v, radius, level


def layouts(n: int, seed: int = 0) -> list[Layout]:
    """``n`` layouts, spread evenly over sizes and conditions."""
    rng = np.random.default_rng(seed)
    out = []
    cells = [(s, c) for s in SIZES for c in CONDITIONS]
    for i in range(n):
        size, condition = cells[i % len(cells)]
        hard = condition == "hard"
        distance = FX * 25.0 / size
        poses = []
        slots = [(-200.0, -110.0), (0.0, 100.0), (200.0, -110.0)]
        for u, v in slots:
            jitter = rng.uniform(-60, 60, 2)
            offset = ((u + jitter[0]) * distance / FX, (v + jitter[1]) * distance / FX)
            tilt = 60.0 if hard else 30.0
            rvec, tvec = syn.look_at_pose(
                distance, rng.uniform(-tilt, tilt), rng.uniform(0, 360), offset_mm=offset
            )
            rot, _ = cv2.Rodrigues(rvec)
            b = np.radians(rng.uniform(-tilt, tilt) / 2)
            turn = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
            poses.append((cv2.Rodrigues(rot @ turn)[0].reshape(3), tvec))
        cover = None
        if hard and rng.random() < 1 / 3:
            cover = (
                int(rng.integers(3)),
                float(rng.uniform(-0.5, 0.5)),
                float(rng.uniform(-0.5, 0.5)),
                float(rng.uniform(0.18, 0.31)),  # 10-30 % of the square's area
                float(rng.choice([rng.uniform(20, 60), rng.uniform(190, 240)])),
            )
        out.append(
            Layout(
                size_px=size,
                condition=condition,
                poses=poses,
                picks=[int(x) for x in rng.integers(0, 1 << 30, 3)],
                backdrop=int(rng.integers(0, 32)),
                light=float(rng.uniform(0.45, 0.8)) if hard else 1.0,
                light_angle=float(rng.uniform(0, 360)),
                shadow=float(rng.uniform(0.55, 0.8)) if hard and rng.random() < 0.5 else 1.0,
                shadow_x=float(rng.uniform(0.0, 0.8)),
                blur=float(rng.uniform(0.5, 1.2 if hard else 1.0)),
                noise=float(rng.uniform(2.0, 5.0 if hard else 4.0)),
                noise_seed=int(rng.integers(1 << 30)),
                cover=cover,
            )
        )
    return out


@dataclass
class Truth:
    """A frame's markers: ids, corners (4, 2) and whether each is partly covered."""

    ids: list[int]
    corners: list[np.ndarray]
    covered: list[bool] = field(default_factory=list)


_BACKDROPS: list[np.ndarray] = []


def backdrop(index: int) -> np.ndarray:
    """One of 32 cluttered desks (float32), made once."""
    while len(_BACKDROPS) <= index:
        _BACKDROPS.append(syn.cluttered(W, H, seed=1000 + len(_BACKDROPS)))
    return _BACKDROPS[index]


def draw_marker(image: np.ndarray, texture: np.ndarray, full_mm: float, rvec, tvec) -> None:
    """Draw ``texture`` (a marker and its quiet zone, ``full_mm`` wide) at its pose, warping
    only the marker's bounding box (supersampled, averaged down) into the float image."""
    half = full_mm / 2.0
    square = np.array([[-half, half, 0], [half, half, 0], [half, -half, 0], [-half, -half, 0]])
    pts, _ = cv2.projectPoints(square, rvec, tvec, K, np.zeros(5))
    pts = pts.reshape(4, 2)
    x0, y0 = np.floor(pts.min(axis=0)).astype(int) - 1
    x1, y1 = np.ceil(pts.max(axis=0)).astype(int) + 2
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
    if x1 <= x0 or y1 <= y0:
        return
    s = SUPERSAMPLE
    n = texture.shape[0]
    src = np.array([[0, 0], [n, 0], [n, n], [0, n]], np.float32) - 0.5
    dst = ((pts - [x0, y0] + 0.5) * s - 0.5).astype(np.float32)
    homography = cv2.getPerspectiveTransform(src, dst)
    size = ((x1 - x0) * s, (y1 - y0) * s)
    warped = cv2.warpPerspective(texture, homography, size, flags=cv2.INTER_LINEAR)
    mask = cv2.warpPerspective(np.ones_like(texture), homography, size, flags=cv2.INTER_LINEAR)
    warped = cv2.resize(warped, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA)
    mask = cv2.resize(mask, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA)
    roi = image[y0:y1, x0:x1]
    roi *= 1.0 - mask
    roi += warped


_TEXTURES: dict[tuple[str, int], tuple[np.ndarray, float]] = {}


def texture(family: str, marker_id: int) -> tuple[np.ndarray, float]:
    """A marker with a 1.5-cell quiet zone as print levels (30 black, 220 white), float32, and
    its width over the black square's."""
    key = (family, marker_id)
    if key not in _TEXTURES:
        generator, dictionary = FAMILIES[family]
        cells = cells_per_side(generator, dictionary)
        side = 120 - 120 % cells
        image = marker_image(generator, marker_id, side, dictionary, quiet_cells=1.5)
        _TEXTURES[key] = (image.astype(np.float32) * (190.0 / 255.0) + 30.0, image.shape[0] / side)
    return _TEXTURES[key]


_NOISE: list[np.ndarray] = []


def noise_field(seed: int) -> np.ndarray:
    """Unit-sd sensor noise for a frame: one of 16 fields, rolled by a seeded offset."""
    if not _NOISE:
        rng = np.random.default_rng(99)
        _NOISE.extend(rng.standard_normal((H, W)).astype(np.float32) for _ in range(16))
    rng = np.random.default_rng(seed)
    base = _NOISE[int(rng.integers(16))]
    return np.roll(base, (int(rng.integers(H)), int(rng.integers(W))), axis=(0, 1))


def render(family: str, layout: Layout, pool: list[int]) -> tuple[np.ndarray, Truth]:
    """The frame of ``layout`` with ``family``'s markers (grey uint8) and its truth."""
    image = backdrop(layout.backdrop).copy()
    truth = Truth([], [], [])
    for k, ((rvec, tvec), pick) in enumerate(zip(layout.poses, layout.picks, strict=True)):
        marker_id = pool[pick % len(pool)]
        while marker_id in truth.ids:
            pick += 1
            marker_id = pool[pick % len(pool)]
        tex, scale = texture(family, marker_id)
        draw_marker(image, tex, 25.0 * scale, rvec, tvec)
        truth.ids.append(marker_id)
        truth.corners.append(syn.project_corners(25.0, K, rvec, tvec))
        truth.covered.append(layout.cover is not None and layout.cover[0] == k)
    if layout.cover is not None:
        k, u, v, radius, level = layout.cover
        corners = truth.corners[k]
        centre = (
            corners.mean(axis=0) + u * (corners[1] - corners[0]) + v * (corners[3] - corners[0])
        )
        side = float(np.linalg.norm(corners[1] - corners[0]))
        axes = (max(1, int(radius * side * 1.3)), max(1, int(radius * side * 0.8)))
        cv2.ellipse(image, (int(centre[0]), int(centre[1])), axes, u * 180.0, 0, 360, level, -1)
    effects = syn.Effects(
        blur=layout.blur,
        light=layout.light,
        light_angle_deg=layout.light_angle,
        shadow=layout.shadow,
        shadow_x=layout.shadow_x,
    )
    out = effects.apply(image).astype(np.float32)
    out += layout.noise * noise_field(layout.noise_seed)
    return np.clip(out + 0.5, 0, 255).astype(np.uint8), truth


def score(dets: list[tuple[int, np.ndarray]], truth: Truth) -> tuple[list[bool], int]:
    """Which truth markers were found (right id within half a side of the centre), and how
    many detections were wrong ids (no marker of that id at that place)."""
    found = [False] * len(truth.ids)
    wrong = 0
    for marker_id, corners in dets:
        centre = np.asarray(corners, float).reshape(4, 2).mean(axis=0)
        hit = False
        for k, (tid, tc) in enumerate(zip(truth.ids, truth.corners, strict=True)):
            side = float(np.linalg.norm(tc[1] - tc[0]) + np.linalg.norm(tc[2] - tc[1])) / 2
            if tid == marker_id and np.linalg.norm(centre - tc.mean(axis=0)) < max(side / 2, 2):
                found[k] = hit = True
        wrong += not hit
    return found, wrong


def contenders(family: str) -> dict[str, object]:
    """Name -> ``detect(image) -> [(id, corners)]`` for the family's tracker and peers."""
    if family == "hamming":
        tracker = HammingTracker()
        adaptive = HammingTracker(Preprocessing(adaptive=True, blur=3))
        out = {
            "hamming tracker": lambda im: [(d.id, d.corners) for d in tracker.detect(_f(im))],
            "  adaptive threshold": lambda im: [(d.id, d.corners) for d in adaptive.detect(_f(im))],
        }
        try:
            import hampy

            def read_hampy(im: np.ndarray) -> list[tuple[int, np.ndarray]]:
                bgr = cv2.cvtColor(im, cv2.COLOR_GRAY2BGR)
                return [(int(m.id), np.asarray(m.contours)) for m in hampy.detect_markers(bgr)]

            out["hampy 1.4.2"] = read_hampy
        except ImportError:
            console.print("hampy is not installed (pip install -e '.[bench]'): no Hampy peer")
        return out
    tracker = ArucoTracker(family)
    name = "apriltag tracker" if family.startswith("apriltag") else "aruco tracker"
    bare = bare_detector(family)

    def read_opencv(im: np.ndarray) -> list[tuple[int, np.ndarray]]:
        corners, ids, _ = bare.detectMarkers(im)
        ids = [] if ids is None else np.asarray(ids).ravel()
        return [(int(i), c) for i, c in zip(ids, corners, strict=True)]

    return {
        name: lambda im: [(d.id, d.corners) for d in tracker.detect(_f(im))],
        "OpenCV detectMarkers": read_opencv,
    }


def bare_detector(dictionary: str) -> cv2.aruco.ArucoDetector:
    """OpenCV's detector with the aruco tracker's own parameters (its minimum side for 640x480)."""
    tracker = ArucoTracker(dictionary)
    tracker.detect(_f(np.full((H, W), 128, np.uint8)))  # sets the perimeter limit for 640x480
    return cv2.aruco.ArucoDetector(get_dictionary(dictionary), tracker.parameters)


def _f(image: np.ndarray) -> Frame:
    return Frame(image, 0.0, K, np.zeros(5))


def detection(n_frames: int, families: list[str]) -> dict[str, list[np.ndarray]]:
    """Print the detection table; return a few frames per family for the speed figure."""
    plan = layouts(n_frames)
    pools = {**ID_POOLS, "hamming": hamming_ids(2000)}
    kept: dict[str, list[np.ndarray]] = {}
    print(
        f"1. markers found and wrong ids, {n_frames} frames of 640x480 per family, three "
        "markers a frame (covered: partly hidden markers, counted apart)"
    )
    for family in families:
        readers = contenders(family)
        cells: dict[tuple[str, str, int], list[int]] = {}
        seconds = dict.fromkeys(readers, 0.0)
        for i, layout in enumerate(
            track(plan, f"{family}: frames", console=console, transient=True)
        ):
            image, truth = render(family, layout, pools[family])
            if i % 25 == 0:
                kept.setdefault(family, []).append(image)
            for name, read in readers.items():
                t0 = time.perf_counter()
                dets = read(image)
                seconds[name] += time.perf_counter() - t0
                found, wrong = score(dets, truth)
                key = (name, layout.condition, layout.size_px)
                c = cells.setdefault(key, [0, 0, 0, 0, 0])
                for hit, covered in zip(found, truth.covered, strict=True):
                    c[2 if covered else 0] += 1
                    c[3 if covered else 1] += hit
                c[4] += wrong
        print(f"   {family}")
        print(f"   {'contender':22s} {'condition':11s}" + "".join(f"{s:>9d}" for s in SIZES)
              + "   covered  wrong ids")  # fmt: skip
        for name in readers:
            for condition in CONDITIONS:
                rates, covered, wrong = [], [0, 0], 0
                for size in SIZES:
                    c = cells.get((name, condition, size), [0, 0, 0, 0, 0])
                    rates.append(f"{100.0 * c[1] / max(c[0], 1):8.1f}%")
                    covered[0] += c[2]
                    covered[1] += c[3]
                    wrong += c[4]
                cov = f"{100.0 * covered[1] / covered[0]:6.1f}%" if covered[0] else "      -"
                print(f"   {name:22s} {condition:11s}" + " ".join(rates) + f"   {cov}  {wrong:6d}")
        total_wrong = {
            name: sum(v[4] for k, v in cells.items() if k[0] == name) for name in readers
        }
        for name in readers:
            print(
                f"      {name}: {total_wrong[name]} wrong ids in {n_frames} frames, "
                f"{1000.0 * seconds[name] / n_frames:.2f} ms a frame on average (wall)"
            )
    return kept


def speed(frames: dict[str, list[np.ndarray]], rounds: int) -> None:
    """Each tracker against OpenCV's detector alone, same frames, best of ``rounds``."""
    print(
        f"2. ms per frame, CPU on {cv2.getNumThreads()} OpenCV threads | wall | CPU on one thread; "
        "tracker / OpenCV's detectMarkers alone (goal <= 1.5x)"
    )
    for family, images in frames.items():
        tracker = HammingTracker() if family == "hamming" else ArucoTracker(family)
        bare = bare_detector("4x4_50" if family == "hamming" else family)
        bgr = [cv2.cvtColor(im, cv2.COLOR_GRAY2BGR) for im in images]
        ms, _ = time_contenders(
            {
                "tracker": (lambda im, t=tracker: t.detect(_f(im)), bgr),
                "bare": (bare.detectMarkers, bgr),
            },
            rounds,
            console,
        )
        print(
            f"   {family:15s} ({len(images)} frames) tracker {ms['tracker', 'cpu']:5.2f} | "
            f"{ms['tracker', 'wall']:5.2f} | {ms['tracker', 'one']:5.2f}  detectMarkers "
            f"{ms['bare', 'cpu']:5.2f} | {ms['bare', 'wall']:5.2f} | {ms['bare', 'one']:5.2f}  "
            f"ratio {ratios(ms, 'tracker', 'bare')}"
        )


def main() -> int:
    """Both figures (fewer frames with --quick)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=10000, help="frames per family")
    parser.add_argument("--rounds", type=int, default=3, help="timing rounds per frame")
    parser.add_argument("--quick", action="store_true", help="700 frames per family")
    parser.add_argument(
        "--families", nargs="+", choices=list(FAMILIES), default=list(FAMILIES), help="families"
    )
    args = parser.parse_args()
    n = 700 if args.quick else args.frames
    kept = detection(n, args.families)
    speed({f: images[:200] for f, images in kept.items()}, args.rounds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
