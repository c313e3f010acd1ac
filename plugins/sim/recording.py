"""Recordings of a simulated run: camera video, overhead video and PNG, score JSON.

The camera video plays at the run's time, at the camera's frame rate: a frame
the camera produced stands in for the frames after it that no one read (the sim
camera renders only the frames skills read), up to the end of the run. The
overhead view is a top-down drawing of the table, the bodies, the
arm's links, the camera's field of view and the planned path, drawn at
``OVERHEAD_FPS`` on the run's clock. Videos are MP4 (mp4v) when OpenCV can
write it, else Motion-JPEG AVI.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from armtree.api.rig import Frame

from .geometry import UNIT_BOX

OVERHEAD_FPS = 10.0
OVERHEAD_SIZE = 640
#: BGR colour of each kind of body in drawings of the world.
KIND_COLORS = {
    "ducky": (40, 205, 250),
    "trash": (90, 110, 130),
    "block": (60, 90, 200),
    "obstacle": (120, 70, 40),
    "bin": (60, 110, 50),
    "spot": (200, 200, 215),
    "duckybot": (50, 50, 60),
}


def write_score(score: dict[str, Any], path: Path) -> None:
    """Write the score as indented JSON (the parent directory must exist)."""
    Path(path).write_text(json.dumps(score, indent=2, sort_keys=True) + "\n")


def open_video(path: Path, fps: float, size: tuple[int, int]) -> tuple[Any, Path]:
    """A cv2.VideoWriter for ``path`` (MP4), falling back to MJPG AVI; returns it and its path."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), fps, size)
    if writer.isOpened():
        return writer, path
    avi = path.with_suffix(".avi")
    writer = cv2.VideoWriter(str(avi), cv2.VideoWriter.fourcc(*"MJPG"), fps, size)
    if not writer.isOpened():
        raise OSError(f"OpenCV cannot write a video to {path} or {avi}")
    return writer, avi


class Overhead:
    """Draws the world seen from above, in a square image scaled to the table."""

    def __init__(self, world: Any, size: int = OVERHEAD_SIZE) -> None:
        self.world = world
        t = world.table
        self.size = size
        span = max(t.x[1] - t.x[0], t.y[1] - t.y[0])
        self.scale = (size - 20) / span
        self.origin = (t.x[0], t.y[0])

    def px(self, xy: np.ndarray) -> np.ndarray:
        """Image pixels of base-frame (x, y) points (x to the right, y up)."""
        xy = np.atleast_2d(np.asarray(xy, dtype=float))[:, :2]
        u = 10 + (xy[:, 0] - self.origin[0]) * self.scale
        v = self.size - 10 - (xy[:, 1] - self.origin[1]) * self.scale
        return np.column_stack([u, v])

    def _poly(self, img, pts, color, filled=True, thickness=1) -> None:
        p = np.round(self.px(pts) * 16).astype(np.int32)
        if filled:
            cv2.fillConvexPoly(img, p, color, cv2.LINE_AA, 4)
        else:
            cv2.polylines(img, [p], True, color, thickness, cv2.LINE_AA, 4)

    def draw(
        self,
        camera: Any = None,
        path_xyz: np.ndarray | None = None,
        trail_xy: list[tuple[float, float]] | None = None,
    ) -> np.ndarray:
        """The overhead image (BGR uint8) of the world's current state.

        ``path_xyz`` is the planned tool path (magenta), ``trail_xy`` where the
        tool has been (cyan).
        """
        w = self.world
        img = np.full((self.size, self.size, 3), 40, np.uint8)
        with w.lock:
            self._poly(img, w.table.polygon(), (150, 185, 210))
            for bot in w.duckybots.values():
                route = [bot.trail[0]] + [leg.target for leg in bot.route]
                for a, b in zip(route[:-1], route[1:], strict=True):
                    pa, pb = self.px(a)[0], self.px(b)[0]
                    cv2.line(
                        img,
                        tuple(int(v) for v in pa),
                        tuple(int(v) for v in pb),
                        (160, 160, 160),
                        1,
                        cv2.LINE_AA,
                    )
                if len(bot.trail) > 1:
                    trail = np.round(self.px(np.array(bot.trail))).astype(np.int32)
                    cv2.polylines(img, [trail], False, (0, 140, 255), 1, cv2.LINE_AA)
            bodies = sorted(w.bodies.values(), key=lambda b: b.top)
            for b in bodies:
                if b.off_table:
                    continue
                color = KIND_COLORS.get(b.kind, (128, 128, 128))
                self._poly(img, b.footprint(), color)
                if b.kind == "bin":
                    self._poly(img, b.footprint(shrink=b.spec.wall), (30, 60, 25))
                if b.marker is not None:
                    c = self.px(b.pose[:2, 3])[0]
                    cv2.putText(
                        img,
                        str(b.marker.id),
                        (int(c[0]) - 4, int(c[1]) + 4),
                        cv2.FONT_HERSHEY_SIMPLEX,
                        0.35,
                        (255, 255, 255),
                        1,
                        cv2.LINE_AA,
                    )
            arm = w.arm
            if arm is not None:
                for p, s in zip(arm.box_poses, arm.box_sizes, strict=True):
                    corners = UNIT_BOX * s @ p[:3, :3].T + p[:3, 3]
                    hull = cv2.convexHull(corners[:, :2].astype(np.float32)).reshape(-1, 2)
                    self._poly(img, hull, (90, 90, 95))
                    self._poly(img, hull, (20, 20, 20), filled=False)
                tip = self.px(arm.tool_pose[:2, 3])[0]
                color = (0, 0, 255) if arm.suction else (255, 255, 255)
                cv2.circle(img, (int(tip[0]), int(tip[1])), 4, color, -1, cv2.LINE_AA)
            if camera is not None:
                fov = self._field_of_view(camera)
                if fov is not None:
                    self._poly(img, fov, (0, 220, 255), filled=False, thickness=2)
            if trail_xy is not None and len(trail_xy) > 1:
                pts = np.round(self.px(np.array(trail_xy))).astype(np.int32)
                cv2.polylines(img, [pts], False, (255, 255, 0), 1, cv2.LINE_AA)
            if path_xyz is not None and len(path_xyz) > 1:
                pts = np.round(self.px(path_xyz)).astype(np.int32)
                cv2.polylines(img, [pts], False, (255, 0, 255), 2, cv2.LINE_AA)
            cv2.putText(
                img,
                f"t = {w.time:7.2f} s",
                (12, 22),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.55,
                (255, 255, 255),
                1,
                cv2.LINE_AA,
            )
        return img

    def _field_of_view(self, camera: Any) -> np.ndarray | None:
        """Where the camera's image corners meet the table plane (mm), or None."""
        cam_pose = self.world.camera_pose(
            camera.mount, getattr(camera, "mounted", camera.extrinsics)
        )
        renderer = getattr(camera, "renderer", None)
        if renderer is None:
            return None
        rays = renderer.camera.field_of_view_rays() @ cam_pose[:3, :3].T
        origin = cam_pose[:3, 3]
        h = self.world.table.height
        if np.any(rays[:, 2] >= -1e-6):
            return None
        t = (h - origin[2]) / rays[:, 2]
        return (origin + rays * t[:, None])[:, :2]


def planned_path_xyz(planner: Any, model: Any) -> np.ndarray | None:
    """Tool positions (N, 3) along the planner's last path, if it exposes ``last_path``."""
    path = getattr(planner, "last_path", None)
    if path is None or model is None:
        return None
    q = np.asarray(path, dtype=float)
    if q.ndim != 2 or len(q) < 2:
        return None
    return model.position(q)


def _video_readable(path: Path) -> bool:
    """Whether the video at ``path`` opens and says it has frames: OpenCV's writers do not
    report a failed write, and an MP4 cut short has no index to open it by."""
    capture = cv2.VideoCapture(str(path))
    try:
        return capture.isOpened() and capture.get(cv2.CAP_PROP_FRAME_COUNT) > 0
    finally:
        capture.release()


class Recorder:
    """Writes the camera and overhead videos of one run into ``directory``."""

    def __init__(self, directory: Any, world: Any, camera: Any, planner: Any = None) -> None:
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.world = world
        self.camera = camera
        self.planner = planner
        self.overhead = Overhead(world)
        self._camera_writer: Any = None
        self._overhead_writer: Any = None
        self.paths: dict[str, Path] = {}
        #: Files of the record that could not be written, ``"name: reason"`` each.
        self.errors: list[str] = []
        self._next_overhead = 0.0
        #: Camera frames rendered during the run (the video holds more: see the module).
        self.frames = 0
        self._camera_next = 0  # index of the camera video's next frame
        self._camera_last: np.ndarray | None = None
        self._now = 0.0
        #: Tool positions (x, y mm) seen so far, for the overhead view.
        self.trail: list[tuple[float, float]] = []
        if camera is not None:
            camera.listeners.append(self._on_frame)

    def _on_frame(self, frame: Frame) -> None:
        image = (
            frame.image if frame.image.ndim == 3 else cv2.cvtColor(frame.image, cv2.COLOR_GRAY2BGR)
        )
        if self._camera_writer is None:
            h, w = image.shape[:2]
            self._camera_writer, self.paths["camera"] = open_video(
                self.directory / "camera.mp4", self.camera.fps, (w, h)
            )
        index = self._camera_next if frame.index is None else int(frame.index)
        if index < self._camera_next:
            return  # a frame rendered again (render_now): the video has it
        # the first frame also stands for the time before it
        self._fill_camera(index, image if self._camera_last is None else self._camera_last)
        self._camera_writer.write(image)
        self._camera_next = index + 1
        self._camera_last = image
        self.frames += 1

    def _fill_camera(self, index: int, image: np.ndarray) -> None:
        """Repeat ``image`` in the camera video up to (not including) frame ``index``."""
        while self._camera_next < index:
            self._camera_writer.write(image)
            self._camera_next += 1

    def _draw(self) -> np.ndarray:
        model = getattr(self.world, "model", None)
        return self.overhead.draw(self.camera, planned_path_xyz(self.planner, model), self.trail)

    def step(self, now: float) -> None:
        """Add overhead frames up to ``now`` (seconds on the run's clock)."""
        self._now = max(self._now, now)
        arm = self.world.arm
        if arm is not None:
            tip = (float(arm.tool_pose[0, 3]), float(arm.tool_pose[1, 3]))
            if (
                not self.trail
                or np.hypot(tip[0] - self.trail[-1][0], tip[1] - self.trail[-1][1]) > 1
            ):
                self.trail.append(tip)
        if now + 1e-9 < self._next_overhead:
            return
        image = self._draw()
        if self._overhead_writer is None:
            self._overhead_writer, self.paths["overhead"] = open_video(
                self.directory / "overhead.mp4", OVERHEAD_FPS, (image.shape[1], image.shape[0])
            )
        while self._next_overhead <= now + 1e-9:
            self._overhead_writer.write(image)
            self._next_overhead += 1.0 / OVERHEAD_FPS

    def finish(self) -> None:
        """Write the final overhead PNG and close the videos (the score is the sim
        plugin's to write)."""
        if self._camera_writer is not None and self._camera_last is not None:
            # the last frame shown lasts until the run's end
            self._fill_camera(
                int(math.floor(self._now * self.camera.fps + 1e-9)) + 1, self._camera_last
            )
        image = self._draw()
        try:
            # Encoded here and written by Python: a failed write is an OSError with its
            # reason, not a line libpng prints on stderr.
            (self.directory / "overhead.png").write_bytes(cv2.imencode(".png", image)[1].tobytes())
            self.paths["overhead_png"] = self.directory / "overhead.png"
        except OSError as exc:
            self.errors.append(f"overhead.png: {exc.strerror or exc}")
        self.close()

    def close(self) -> None:
        """Release the video writers, and note a video that cannot be read back; safe to
        call twice."""
        for attr, key in (("_camera_writer", "camera"), ("_overhead_writer", "overhead")):
            writer = getattr(self, attr)
            if writer is not None:
                writer.release()
                setattr(self, attr, None)
                if not _video_readable(self.paths[key]):
                    self.errors.append(f"{self.paths[key].name}: cut short (is the disk full?)")
        if self.camera is not None and self._on_frame in self.camera.listeners:
            self.camera.listeners.remove(self._on_frame)


__all__ = ["OVERHEAD_FPS", "Overhead", "Recorder", "open_video", "write_score"]
