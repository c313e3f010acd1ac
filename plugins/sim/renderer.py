"""Renders what a camera sees of the simulated world: table, objects, markers, arm, light.

Solids are drawn in painter's order (far to near, back faces culled, the
near plane clipped) with every vertex projected through the pinhole and the
profile's lens distortion (OpenCV's k1, k2, p1, p2, k3), long edges
subdivided so they bend as a real lens bends them. Markers are perspective
warps of the marker image onto their distorted corners, into their small
bounding box only. The table (a texture lit by the lamp) is one remap per
camera pose, through a map computed on a coarse grid and interpolated, and
is cached, so a still camera costs little more than its markers; what each
solid paints is recorded, so one that has not moved under a still camera is
painted again without its arithmetic. Sensor noise comes from a seeded bank of
noise images; motion blur follows the camera's and the objects' image motion
during the exposure.

Units: mm and the robot base frame for the scene; pixels for the image.
"""

from __future__ import annotations

import functools
import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np

from .geometry import BOX_FACES, UNIT_BOX
from .markers import MarkerAtlas
from .scene_spec import LightSpec, MarkerSpec, TableSpec

#: Near clipping distance in front of the camera, mm.
NEAR = 5.0
#: Colour of what lies beyond the table edge (the floor), BGR.
FLOOR = (45, 45, 50)
#: Texture resolution of the table, pixels per mm.
TEXTURE_PPM = 1.0
CYLINDER_SIDES = 16
#: Polygons wider than this (pixels) get their edges subdivided before distortion.
SUBDIVIDE_PX = 100.0
#: Longest motion-blur streak drawn at full resolution, pixels.
STREAK_PX = 2.0
_SHIFT = 4
_SCALE = 1 << _SHIFT


@dataclass
class Drawable:
    """One solid to draw: ``shape`` box, cylinder, bin, spot, link or plate.

    ``pose`` is the centre's 4x4 pose and ``size`` its extents (mm). A
    ``marker`` is drawn on the top face (frame ``marker_pose``: x, y in the
    face, z up). ``container`` names the drawable this one sits inside (a bin) or on (a
    plate on a link), so it is drawn after it. ``velocity`` (mm/s) blurs it in a moving frame.
    """

    name: str
    shape: str
    pose: np.ndarray
    size: np.ndarray
    color: tuple[int, int, int]
    marker: MarkerSpec | None = None
    marker_pose: np.ndarray | None = None
    wall: float = 0.0
    container: str | None = None
    shadow: bool = True
    velocity: np.ndarray | None = None
    tool_mounted: bool = False


class CameraModel:
    """Intrinsics and distortion, and the lens's inverse on a coarse pixel grid.

    ``coarse`` holds, for pixel centres every ``COARSE`` pixels, the ideal
    normalised image coordinates (x/z, y/z) that the lens bends onto them;
    the table is remapped through it.
    """

    COARSE = 8

    def __init__(self, width: int, height: int, k: np.ndarray, dist: np.ndarray) -> None:
        self.width, self.height = int(width), int(height)
        self.k = np.asarray(k, dtype=float).reshape(3, 3)
        self.dist = np.zeros(5) if dist is None else np.asarray(dist, dtype=float).ravel()[:5]
        self.distorted = bool(np.any(np.abs(self.dist) > 0))
        # Plain floats: numpy scalars would make the per-polygon arithmetic slow.
        self._coeffs = tuple(float(v) for v in self.dist)
        self._pinhole = tuple(
            float(v) for v in (self.k[0, 0], self.k[1, 1], self.k[0, 2], self.k[1, 2])
        )
        step = self.COARSE
        # Sample where cv2.resize's pixel-area alignment puts coarse pixel centres.
        xs = np.arange(-(-self.width // step), dtype=np.float32) * step + (step - 1) / 2
        ys = np.arange(-(-self.height // step), dtype=np.float32) * step + (step - 1) / 2
        gx, gy = np.meshgrid(xs, ys)
        pts = np.stack([gx.ravel(), gy.ravel()], axis=1).reshape(-1, 1, 2)
        if self.distorted:
            ideal = cv2.undistortPoints(
                pts,
                self.k,
                self.dist,
                criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 20, 1e-7),
            )
        else:
            ideal = (pts - self.k[[0, 1], [2, 2]].astype(np.float32)) / self.k[
                [0, 1], [0, 1]
            ].astype(np.float32)
        self.coarse = ideal.reshape(len(ys), len(xs), 2).astype(np.float64)
        # Beyond the field of view the distortion polynomial is meaningless: clamp its radius.
        corners = np.array(
            [[0, 0], [self.width, 0], [0, self.height], [self.width, self.height]], np.float32
        )
        if self.distorted:
            und = cv2.undistortPoints(corners.reshape(-1, 1, 2), self.k, self.dist).reshape(-1, 2)
        else:
            und = (corners - self.k[[0, 1], [2, 2]]) / self.k[[0, 1], [0, 1]]
        self.r2_max = 2.0 * float(np.max(np.sum(und.astype(float) ** 2, axis=1)))
        # Side planes of the view frustum (normals pointing inwards), a little wider than the image.
        lo = self.coarse.reshape(-1, 2).min(axis=0) - 0.05
        hi = self.coarse.reshape(-1, 2).max(axis=0) + 0.05
        planes = np.array(
            [[1.0, 0.0, -lo[0]], [-1.0, 0.0, hi[0]], [0.0, 1.0, -lo[1]], [0.0, -1.0, hi[1]]]
        )
        self.frustum = planes / np.linalg.norm(planes, axis=1, keepdims=True)

    def sees(self, centre: np.ndarray, radius: float) -> bool:
        """False when a sphere (camera frame, mm) is certainly outside the view."""
        if centre[2] + radius <= NEAR:
            return False
        return bool(np.all(self.frustum @ centre >= -radius))

    def pixels(self, pc: np.ndarray) -> np.ndarray:
        """Distorted pixel coordinates (N, 2) of camera-frame points (N, 3) with z > 0."""
        inv_z = 1.0 / pc[:, 2]
        x = pc[:, 0] * inv_z
        y = pc[:, 1] * inv_z
        if self.distorted:
            k1, k2, p1, p2, k3 = self._coeffs
            r2 = x * x + y * y
            rc = np.minimum(r2, self.r2_max)
            radial = 1 + rc * (k1 + rc * (k2 + rc * k3))
            xy = x * y
            x, y = (
                x * radial + 2 * p1 * xy + p2 * (r2 + 2 * x * x),
                y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * xy,
            )
        out = np.empty((len(pc), 2))
        fx, fy, cx, cy = self._pinhole
        out[:, 0] = fx * x + cx
        out[:, 1] = fy * y + cy
        return out

    def field_of_view_rays(self) -> np.ndarray:
        """Unit rays (4, 3) through the image corners in the camera frame (distortion ignored)."""
        w, h = self.width, self.height
        px = np.array([[0, 0], [w, 0], [w, h], [0, h]], dtype=float)
        rays = np.column_stack(
            [
                (px[:, 0] - self.k[0, 2]) / self.k[0, 0],
                (px[:, 1] - self.k[1, 2]) / self.k[1, 1],
                np.ones(4),
            ]
        )
        return rays / np.linalg.norm(rays, axis=1, keepdims=True)


def texture_noise(
    table: TableSpec, rng: np.random.Generator
) -> tuple[np.ndarray | None, np.ndarray]:
    """The random numbers of the table's texture, drawn from ``rng``: the wood's grain
    (None for the other textures) and the speckle, both one per texture pixel."""
    w = max(2, int(round((table.x[1] - table.x[0]) * TEXTURE_PPM)))
    h = max(2, int(round((table.y[1] - table.y[0]) * TEXTURE_PPM)))
    grain = rng.standard_normal((h, w)) if table.texture == "wood" else None
    return grain, rng.normal(0, 4, (h, w, 1))


def table_texture(
    table: TableSpec, light: LightSpec, noise: tuple[np.ndarray | None, np.ndarray]
) -> np.ndarray:
    """The table top as a BGR image (1 px per mm), lit by the lamp: wood, plain or checker.

    ``noise`` is the texture's random numbers, from :func:`texture_noise`.
    """
    grain_noise, speckle = noise
    h, w = speckle.shape[:2]
    # A row of x and a column of y: broadcast, they give the numbers a full grid of each would.
    gx = np.linspace(table.x[0], table.x[1], w, dtype=np.float32)[None, :]
    gy = np.linspace(table.y[0], table.y[1], h, dtype=np.float32)[:, None]
    if grain_noise is not None:
        wobble = cv2.GaussianBlur(grain_noise.astype(np.float32), (0, 0), 25) * 60
        grain = 0.5 + 0.5 * np.sin((gy + wobble) * 0.35 + 2.0 * np.sin(gx * 0.01))
        base = np.array([100, 150, 190], dtype=np.float32)
        img = base * (0.85 + 0.15 * grain[..., None])
    elif table.texture == "checker":
        cells = ((np.floor(gx / 50) + np.floor(gy / 50)) % 2)[..., None]
        img = np.where(cells > 0, 200.0, 150.0) * np.ones(3, dtype=np.float32)
    else:
        img = np.full((h, w, 3), 185.0, dtype=np.float32)
    img += speckle.astype(np.float32)
    img *= light_level(light, gx, gy, table.height)[..., None]
    return np.clip(img, 0, 255, out=img).astype(np.uint8)


def light_level(light: LightSpec, x: np.ndarray, y: np.ndarray, z: float) -> np.ndarray:
    """Relative brightness (0-1.2) of a horizontal surface at (x, y, z) under the lamp."""
    lx, ly, lz = light.position
    dz = lz - z
    d2 = (x - lx) ** 2 + (y - ly) ** 2 + dz * dz
    # Lambert's cosine over the inverse square, normalised to 1 right under the lamp.
    direct = (dz / np.sqrt(d2)) * (dz * dz / d2)
    return light.ambient + (1.0 - light.ambient) * direct * 1.2


class Renderer:
    """Draws frames of one camera; deterministic for its seed and the frame index."""

    def __init__(
        self,
        camera: CameraModel,
        table: TableSpec,
        light: LightSpec,
        seed: int = 0,
        noise: float = 3.0,
        blur: float = 0.0,
        exposure: float = 0.02,
        shadows: bool = True,
    ) -> None:
        self.camera = camera
        self.table = table
        self.light = light
        self.noise = float(noise)
        self.blur = float(blur)
        self.exposure = float(exposure)
        self.shadows = shadows
        self.seed = int(seed)
        rng = np.random.default_rng([self.seed, 7])
        texture = texture_noise(table, rng)
        # The noise bank draws on from the same generator, which the texture is done with: it
        # is drawn while the texture is shaded, both releasing the GIL, on a second core if idle.
        with ThreadPoolExecutor(max_workers=1) as pool:
            bank = pool.submit(
                _noise_bank, rng, (camera.height + 16, camera.width + 16, 3), self.noise
            )
            self.texture = table_texture(table, light, texture)
            self.texture_small = cv2.resize(
                self.texture, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA
            )
        self.atlas = MarkerAtlas()
        self._bg_key: bytes | None = None
        self._clean_key: bytes | None = None
        self._clean: np.ndarray | None = None
        self._lens_blurred: np.ndarray | None = None
        # The last clean image blurred, its blur and its table image, to blur again only
        # what changed.
        self._last_blur: tuple[np.ndarray, np.ndarray, np.ndarray | None] | None = None
        self._bg: np.ndarray | None = None
        self._bg_shaded: np.ndarray | None = None
        self._noise_bank = bank.result()
        # What the last frame drew from camera pose ``_memo_camera``: each solid's strokes
        # and each shadow's outline, to be reused while neither it nor the camera moves.
        self._memo_camera: bytes | None = None
        self._strokes: dict[tuple, _Strokes | None] = {}
        self._shadow_outlines: dict[tuple, tuple[np.ndarray, np.ndarray] | None] = {}
        tex_to_world = np.array(
            [[1 / TEXTURE_PPM, 0, table.x[0]], [0, 1 / TEXTURE_PPM, table.y[0]], [0, 0, 1]]
        )
        self._tex_to_world = tex_to_world

    # -- public -----------------------------------------------------------------

    def render(
        self,
        cam_pose: np.ndarray,
        drawables: list[Drawable],
        frame_index: int = 0,
        previous_pose: np.ndarray | None = None,
        frame_dt: float = 1 / 30,
    ) -> np.ndarray:
        """The image (H x W x 3 BGR uint8) seen from ``cam_pose`` (camera-to-base, OpenCV axes).

        ``previous_pose`` is where the camera was one frame (``frame_dt`` s)
        earlier, for motion blur.
        """
        key = _scene_key(cam_pose, drawables)
        if key != self._clean_key or self._clean is None:
            self._clean_key, self._clean = key, self._draw_scene(cam_pose, drawables)
            self._lens_blurred = None
        img = self._clean  # nothing moved: only the blur of a moving camera and noise change
        streak = None
        if previous_pose is not None:
            streak = self._camera_streak(cam_pose, previous_pose, frame_dt)
        if streak is not None:
            # A streak of a pixel or more hides the lens's own sub-pixel blur.
            img = _streak(img, streak)
        elif self.blur > 0:
            if self._lens_blurred is None:
                self._lens_blurred = self._lens_blur(img)
            img = self._lens_blurred
        if self._noise_bank:
            return self._add_noise(img, frame_index)
        return img.copy() if img is self._clean or img is self._lens_blurred else img

    def _lens_blur(self, clean: np.ndarray) -> np.ndarray:
        """The lens's blur of ``clean``, worked out again only around the pixels that differ
        from the last clean image blurred (a blurred pixel depends only on its neighbours)."""
        ksize = (3, 3) if self.blur <= 0.8 else (0, 0)
        last, self._last_blur = self._last_blur, None
        if last is not None and last[2] is not self._bg:
            last = None  # the camera moved: most of the image changed
        box = None if last is None else _changed_box(last[0], clean)
        h, w = clean.shape[:2]
        if last is None or (box is not None and (box[2] - box[0]) * (box[3] - box[1]) > h * w / 2):
            blurred = cv2.GaussianBlur(clean, ksize, self.blur)
        else:
            # Frames leave as copies or with noise added, never as this array: update it.
            blurred = last[1]
            if box is not None:
                # Past the kernel's radius (at most ``m``) nothing changes, and pixels up to
                # ``m`` past the box are blurred from a crop that reaches ``2 m`` past it.
                m = int(3 * self.blur) + 2
                x0, y0, x1, y1 = box
                cx0, cy0 = max(x0 - 2 * m, 0), max(y0 - 2 * m, 0)
                crop = np.ascontiguousarray(
                    clean[cy0 : min(y1 + 2 * m, h), cx0 : min(x1 + 2 * m, w)]
                )
                part = cv2.GaussianBlur(crop, ksize, self.blur)
                px0, py0, px1, py1 = max(x0 - m, 0), max(y0 - m, 0), min(x1 + m, w), min(y1 + m, h)
                blurred[py0:py1, px0:px1] = part[py0 - cy0 : py1 - cy0, px0 - cx0 : px1 - cx0]
        self._last_blur = (clean, blurred, self._bg)
        return blurred

    def _draw_scene(self, cam_pose: np.ndarray, drawables: list[Drawable]) -> np.ndarray:
        """Table, shadows and solids: everything but blur and noise."""
        r_cw = cam_pose[:3, :3].T
        t_cw = -r_cw @ cam_pose[:3, 3]
        img = self._background(r_cw, t_cw).copy()
        cam_pos = cam_pose[:3, 3]
        cam_key = cam_pose.tobytes()
        if cam_key != self._memo_camera:
            self._memo_camera, self._strokes, self._shadow_outlines = cam_key, {}, {}
        if self.shadows:
            self._draw_shadows(img, drawables, r_cw, t_cw)
        # What a drawable paints depends only on it and the camera pose: one that has not
        # moved since the last frame, under a camera that has not moved, paints it again.
        known, self._strokes = self._strokes, {}
        visible: list[tuple[Drawable, _Strokes]] = []
        for d in drawables:
            key = _drawable_key(d)
            if key not in self._strokes:
                self._strokes[key] = (
                    known[key] if key in known else self._strokes_of(d, r_cw, t_cw, cam_pos)
                )
            strokes = self._strokes[key]
            if strokes is not None:
                visible.append((d, strokes))
        for _, seen in self._order(visible):
            seen.paint(img)
        return img

    def project(self, cam_pose: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Distorted pixel coordinates (N, 2) of base-frame points (N, 3) in front of the camera."""
        r_cw = cam_pose[:3, :3].T
        t_cw = -r_cw @ cam_pose[:3, 3]
        rvec, _ = cv2.Rodrigues(r_cw)
        px, _ = cv2.projectPoints(
            np.asarray(points, dtype=np.float64).reshape(-1, 1, 3),
            rvec,
            t_cw,
            self.camera.k,
            self.camera.dist,
        )
        return px.reshape(-1, 2)

    # -- background ---------------------------------------------------------------

    def _background(self, r_cw: np.ndarray, t_cw: np.ndarray) -> np.ndarray:
        key = np.concatenate([r_cw.ravel(), t_cw]).round(4).tobytes()
        if key == self._bg_key and self._bg is not None:
            return self._bg
        cam = self.camera
        h = self.table.height
        # Table plane (texture pixels) -> normalised image plane, and back.
        plane = (
            np.column_stack([r_cw[:, 0], r_cw[:, 1], r_cw[:, 2] * h + t_cw]) @ self._tex_to_world
        )
        inverse = np.linalg.inv(plane)
        g = cam.coarse
        hom = g[..., 0:1] * inverse[:, 0] + g[..., 1:2] * inverse[:, 1] + inverse[:, 2]
        w = hom[..., 2]
        valid = w > 1e-9
        # Rays that never meet the table in front of the camera see the floor colour.
        safe = np.where(valid, w, 1.0)
        mx: np.ndarray = np.where(valid, hom[..., 0] / safe, -10.0).astype(np.float32)
        my: np.ndarray = np.where(valid, hom[..., 1] / safe, -10.0).astype(np.float32)
        # The table is smooth: remapping it at a quarter of the resolution and scaling
        # up costs a sixteenth.
        quarter = ((cam.width + 3) // 4, (cam.height + 3) // 4)
        mx = cv2.resize(mx, quarter, interpolation=cv2.INTER_LINEAR)
        my = cv2.resize(my, quarter, interpolation=cv2.INTER_LINEAR)
        small = cv2.remap(
            self.texture_small,
            mx * 0.5 - 0.25,
            my * 0.5 - 0.25,
            cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=FLOOR,
        )
        bg = cv2.resize(small, (cam.width, cam.height), interpolation=cv2.INTER_LINEAR)
        self._bg_key, self._bg, self._bg_shaded = key, bg, None
        return bg

    # -- solids -------------------------------------------------------------------

    def _strokes_of(
        self, d: Drawable, r_cw: np.ndarray, t_cw: np.ndarray, cam_pos: np.ndarray
    ) -> _Strokes | None:
        """What ``d`` paints seen from this camera pose; None when it is out of view."""
        if not self.camera.sees(r_cw @ d.pose[:3, 3] + t_cw, 0.5 * float(np.linalg.norm(d.size))):
            return None
        strokes = _Strokes(float(np.linalg.norm(d.pose[:3, 3] - cam_pos)))
        self._draw(strokes, d, r_cw, t_cw, cam_pos)
        return strokes

    def _order(self, visible: list[tuple[Drawable, _Strokes]]) -> list[tuple[Drawable, _Strokes]]:
        depth = {d.name: seen.depth for d, seen in visible}
        key = {}
        for d, _ in visible:
            k = depth[d.name]
            if d.container in depth:
                # Inside a bin: drawn just after it, whatever the distances say.
                k = min(k, depth[d.container] - 1e-3)
            key[d.name] = k
        return sorted(visible, key=lambda v: -key[v[0].name])

    def _pixels(
        self, pts: np.ndarray, r_cw: np.ndarray, t_cw: np.ndarray, subdivide: bool = True
    ) -> np.ndarray | None:
        """Distorted pixels of a convex world polygon (clipped to the near plane), or None."""
        pc = pts @ r_cw.T + t_cw
        if (pc[:, 2] <= NEAR).any():
            pc = _clip_near(pc)
            if len(pc) < 3:
                return None
        uv = self.camera.pixels(pc)
        span = float((uv.max(axis=0) - uv.min(axis=0)).max())
        if span > 1e5:
            return None
        if subdivide and self.camera.distorted and span > SUBDIVIDE_PX:
            # Long edges bend through the lens: subdivide them before distorting.
            n = min(16, int(span // SUBDIVIDE_PX) + 1)
            t = _fractions(n)
            nxt = pc[np.r_[1 : len(pc), 0]]
            edges = pc[None, :, :] + t * (nxt - pc)[None, :, :]
            uv = self.camera.pixels(edges.transpose(1, 0, 2).reshape(-1, 3))
        return uv

    def _fill(
        self, strokes: _Strokes, pts: np.ndarray, r_cw: np.ndarray, t_cw: np.ndarray, color
    ) -> np.ndarray | None:
        """Fill a convex world polygon; returns its pixels or None if not in front."""
        uv = self._pixels(pts, r_cw, t_cw)
        if uv is not None:
            strokes.polygon(np.round(uv * _SCALE).astype(np.int32), color)
        return uv

    def _draw(
        self,
        strokes: _Strokes,
        d: Drawable,
        r_cw: np.ndarray,
        t_cw: np.ndarray,
        cam_pos: np.ndarray,
    ) -> None:
        if d.shape == "link" and _contains(d, cam_pos):
            return  # the camera sits inside its own mount: it sees out of it, not its inside
        rot = d.pose[:3, :3]
        size = np.asarray(d.size, dtype=float)
        mesh = (
            _cylinder_mesh(*map(float, size))
            if d.shape == "cylinder"
            else _box_mesh(*map(float, size))
        )
        world = mesh.vertices @ rot.T + d.pose[:3, 3]
        normals = mesh.normals @ rot.T
        centres = mesh.centres @ rot.T + d.pose[:3, 3]
        facing = np.einsum("ij,ij->i", normals, cam_pos - centres) > 0
        to_light = np.asarray(self.light.position) - centres
        to_light /= np.linalg.norm(to_light, axis=1, keepdims=True)
        lam = np.maximum(0.0, np.einsum("ij,ij->i", normals, to_light))
        shade = self.light.ambient + (1 - self.light.ambient) * lam
        base = np.asarray(d.color, dtype=float)
        pc = world @ r_cw.T + t_cw
        # All vertices in front: project them once; faces index into them.
        uv_all = self.camera.pixels(pc) if np.all(pc[:, 2] > NEAR) else None
        # Per-face colours and fixed-point pixels for all faces at once (the same numbers).
        colors = np.minimum(255.0, base * shade[:, None]).tolist()
        fixed_all = None if uv_all is None else np.round(uv_all * _SCALE).astype(np.int32)
        bbox = []
        for i in np.flatnonzero(facing):
            color = tuple(colors[i])
            face = list(mesh.faces[i])
            pts = world[face]
            if d.shape == "bin" and normals[i, 2] > 0.9:
                self._draw_bin_top(strokes, d, pts, r_cw, t_cw, color)
                continue
            uv = None if uv_all is None else uv_all[face]
            if uv is None or (
                self.camera.distorted and (uv.max(axis=0) - uv.min(axis=0)).max() > SUBDIVIDE_PX
            ):
                uv = self._fill(strokes, pts, r_cw, t_cw, color)
            else:
                assert fixed_all is not None  # made with uv_all
                strokes.polygon(fixed_all[face], color)
            if uv is not None:
                bbox.append(uv)
        if d.marker is not None and d.marker_pose is not None:
            top_normal = d.marker_pose[:3, 2]
            if top_normal @ (cam_pos - d.marker_pose[:3, 3]) > 0:
                self._draw_marker(strokes, d, r_cw, t_cw)
        if d.velocity is not None and bbox:
            self._object_blur(strokes, d, np.vstack(bbox), r_cw, t_cw)

    def _draw_bin_top(self, strokes: _Strokes, d: Drawable, pts, r_cw, t_cw, color) -> None:
        """A bin seen from above: its rim, then its dark inside down to the floor."""
        self._fill(strokes, pts, r_cw, t_cw, color)
        w = d.wall
        sx, sy, sz = d.size
        inner = UNIT_BOX[4:] * [sx - 2 * w, sy - 2 * w, sz]
        rim = inner @ d.pose[:3, :3].T + d.pose[:3, 3]
        floor = rim - d.pose[:3, 2] * (sz - w)
        self._fill(strokes, rim, r_cw, t_cw, tuple(0.45 * c for c in color))
        self._fill(strokes, floor, r_cw, t_cw, tuple(0.6 * c for c in color))

    def _draw_marker(self, strokes: _Strokes, d: Drawable, r_cw, t_cw) -> None:
        marker = d.marker
        assert marker is not None and d.marker_pose is not None
        s = marker.size_mm / 2
        # Printed on a white label a little larger than the marker (its quiet zone).
        q = min(s * 1.25, 0.5 * float(min(d.size[0], d.size[1])))
        rot, centre = d.marker_pose[:3, :3], d.marker_pose[:3, 3] + d.marker_pose[:3, 2] * 0.01
        light = float(light_level(self.light, centre[0], centre[1], centre[2]))
        white = (min(255.0, 235 * light),) * 3
        square = np.array([[-1, 1, 0], [1, 1, 0], [1, -1, 0], [-1, -1, 0]], dtype=float)
        both = np.vstack([square * q, square * s]) @ rot.T + centre
        pc = both @ r_cw.T + t_cw
        if np.any(pc[:, 2] <= NEAR):
            self._fill(strokes, both[:4], r_cw, t_cw, white)
            return
        uv_both = self.camera.pixels(pc)
        strokes.polygon(np.round(uv_both[:4] * _SCALE).astype(np.int32), white)
        uv = uv_both[4:]
        ih, iw = self.camera.height, self.camera.width
        x0, y0 = np.floor(uv.min(axis=0)).astype(int) - 1
        x1, y1 = np.ceil(uv.max(axis=0)).astype(int) + 2
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, iw), min(y1, ih)
        if x1 <= x0 or y1 <= y0:
            return
        side = float(np.max(np.linalg.norm(uv[[1, 2, 3, 0]] - uv, axis=1)))
        src_img = self.atlas.image(marker, side)
        n = src_img.shape[0]
        src = np.array(
            [[-0.5, -0.5], [n - 0.5, -0.5], [n - 0.5, n - 0.5], [-0.5, n - 0.5]], dtype=np.float32
        )
        h = cv2.getPerspectiveTransform(src, (uv - [x0, y0]).astype(np.float32))
        patch = cv2.warpPerspective(
            src_img,
            h,
            (x1 - x0, y1 - y0),
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=0,
        )
        lit = cv2.cvtColor(cv2.convertScaleAbs(patch, alpha=light), cv2.COLOR_GRAY2BGR)
        strokes.paste(x0, y0, lit, patch)

    # -- shadows ------------------------------------------------------------------

    def _draw_shadows(self, img: np.ndarray, drawables: list[Drawable], r_cw, t_cw) -> None:
        """Shadows cast on the table by the point lamp (Showers 2016 notes moving shadows).

        ``img`` is still the bare table (the background) when they are drawn.
        """
        lamp = np.asarray(self.light.position, dtype=float)
        h = self.table.height
        casters = [d for d in drawables if d.shadow and d.shape != "spot"]
        if not casters:
            return
        sizes = np.array([d.size for d in casters], dtype=float)
        poses = np.array([d.pose for d in casters])
        corners = np.einsum("kj,bij->bki", UNIT_BOX, poses[:, :3, :3] * sizes[:, None, :])
        corners += poses[:, None, :3, 3]
        z = corners[..., 2]
        keep = ~np.all(z <= h + 0.5, axis=1) & np.all(z < lamp[2] - 1.0, axis=1)
        if not np.any(keep):
            return
        corners, z = corners[keep], z[keep]
        t = (h - lamp[2]) / (z - lamp[2])
        ground = lamp[:2] + (corners[..., :2] - lamp[:2]) * t[..., None]
        centres = ground.mean(axis=1)
        radii = np.max(np.linalg.norm(ground - centres[:, None], axis=2), axis=1)
        cc = np.column_stack([centres, np.full(len(centres), h)]) @ r_cw.T + t_cw
        polys: list[tuple[np.ndarray, np.ndarray]] = []
        # An outline depends only on these numbers and the camera pose: reuse last frame's.
        known, self._shadow_outlines = self._shadow_outlines, {}
        for g, c, r in zip(ground, cc, radii, strict=True):
            key = (g.tobytes(), c.tobytes(), float(r))
            if key not in self._shadow_outlines:
                self._shadow_outlines[key] = (
                    known[key] if key in known else self._shadow_outline(g, c, float(r), r_cw, t_cw)
                )
            outline = self._shadow_outlines[key]
            if outline is not None:
                polys.append(outline)
        if not polys:
            return
        ih, iw = img.shape[:2]
        allpts = np.vstack([uv for uv, _ in polys])
        x0, y0 = np.maximum(np.floor(allpts.min(axis=0)).astype(int), 0)
        x1, y1 = np.minimum(np.ceil(allpts.max(axis=0)).astype(int) + 1, [iw, ih])
        if x1 <= x0 or y1 <= y0:
            return
        mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
        # The offset is in the points' fixed-point units; x0 and y0 are whole pixels, so this
        # is the same as rounding the pixels less (x0, y0).
        offset = (-int(x0) * _SCALE, -int(y0) * _SCALE)
        cv2.fillPoly(mask, [fixed for _, fixed in polys], 255, cv2.LINE_8, _SHIFT, offset)
        if self._bg_shaded is None:
            assert self._bg is not None  # the table was drawn before its shadows
            # The lamp's direct light is blocked: what is left is the ambient share (plus some
            # bounce). Shadows fall on the bare table, so it is darkened once per camera pose.
            alpha = min(1.0, self.light.ambient + 0.1)
            self._bg_shaded = cv2.convertScaleAbs(self._bg, alpha=alpha)
        cv2.copyTo(self._bg_shaded[y0:y1, x0:x1], mask, img[y0:y1, x0:x1])

    def _shadow_outline(
        self, ground: np.ndarray, centre: np.ndarray, radius: float, r_cw, t_cw
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """Pixels and fixed-point pixels of the outline of a shadow with corners ``ground``
        (x, y mm on the table), centre ``centre`` (camera frame) and radius ``radius`` (mm);
        None when out of view."""
        if not self.camera.sees(centre, radius):
            return None
        hull = cv2.convexHull(ground.astype(np.float32)).reshape(-1, 2)
        # Shadow edges are soft: no need to bend them through the lens.
        uv = self._pixels(
            np.column_stack([hull, np.full(len(hull), self.table.height)]),
            r_cw,
            t_cw,
            subdivide=False,
        )
        return None if uv is None else (uv, np.round(uv * _SCALE).astype(np.int32))

    # -- blur and noise -------------------------------------------------------------

    def _camera_streak(self, pose_now, pose_before, frame_dt) -> np.ndarray | None:
        """Image motion (pixels) of the view's centre during the exposure, or None below 1 px."""
        ahead = pose_now[:3, :3] @ np.array([0, 0, 1.0])
        depth = (
            (pose_now[2, 3] - self.table.height) / max(1e-6, -ahead[2])
            if ahead[2] < -0.1
            else 300.0
        )
        point = pose_now[:3, 3] + ahead * depth
        r_b = pose_before[:3, :3].T
        pc = r_b @ (point - pose_before[:3, 3])
        if pc[2] <= NEAR:
            return None
        k = self.camera.k
        moved = np.array(
            [
                k[0, 0] * pc[0] / pc[2] + k[0, 2] - k[0, 2],
                k[1, 1] * pc[1] / pc[2] + k[1, 2] - k[1, 2],
            ]
        )
        streak = -moved * min(1.0, self.exposure / max(frame_dt, 1e-6))
        return streak if float(np.hypot(*streak)) >= 1.0 else None

    def _object_blur(self, strokes: _Strokes, d: Drawable, bbox, r_cw, t_cw) -> None:
        assert d.velocity is not None
        centre = d.pose[:3, 3]
        ahead = centre + d.velocity * self.exposure
        pc = np.array([centre, ahead]) @ r_cw.T + t_cw
        if np.any(pc[:, 2] <= NEAR):
            return
        uv = self.camera.pixels(pc)
        streak = uv[1] - uv[0]
        if np.hypot(*streak) < 1.0:
            return
        pad = int(np.ceil(np.abs(streak).max())) + 2
        ch, cw = self.camera.height, self.camera.width
        x0, y0 = np.maximum(np.floor(bbox.min(axis=0)).astype(int) - pad, 0)
        x1, y1 = np.ceil(bbox.max(axis=0)).astype(int) + pad
        x1, y1 = min(x1, cw), min(y1, ch)
        if x1 > x0 and y1 > y0:
            strokes.blur(x0, y0, x1, y1, streak)

    def _add_noise(self, img: np.ndarray, frame_index: int) -> np.ndarray:
        rng = np.random.default_rng([self.seed, 11, frame_index])
        pos, neg = self._noise_bank[int(rng.integers(len(self._noise_bank)))]
        dy, dx = (int(v) for v in rng.integers(0, 16, 2))
        h, w = img.shape[:2]
        img = cv2.add(img, pos[dy : dy + h, dx : dx + w])
        return cv2.subtract(img, neg[dy : dy + h, dx : dx + w])


class _Strokes:
    """What one drawable paints seen from one camera pose, recorded to be painted again.

    ``depth`` is the distance (mm) from the camera to the drawable's centre, for
    painter's order.
    """

    def __init__(self, depth: float) -> None:
        self.depth = depth
        self._ops: list[tuple] = []

    def polygon(self, fixed: np.ndarray, color: tuple) -> None:
        """Fill a polygon of fixed-point pixels (``_SHIFT`` fraction bits), anti-aliased."""
        self._ops.append((_fill_polygon, fixed, color))

    def paste(self, x0: int, y0: int, patch: np.ndarray, mask: np.ndarray) -> None:
        """Copy ``patch`` where ``mask`` is not 0, its top left corner at pixel (x0, y0)."""
        self._ops.append((_paste, x0, y0, patch, mask))

    def blur(self, x0: int, y0: int, x1: int, y1: int, streak: np.ndarray) -> None:
        """Streak what is painted so far in pixels x0..x1, y0..y1 (exclusive) along ``streak``."""
        self._ops.append((_blur_box, x0, y0, x1, y1, streak))

    def paint(self, img: np.ndarray) -> None:
        """Paint the recorded strokes on ``img``, in the order they were recorded."""
        for op, *args in self._ops:
            op(img, *args)


def _fill_polygon(img: np.ndarray, fixed: np.ndarray, color: tuple) -> None:
    cv2.fillPoly(img, [fixed], color, cv2.LINE_AA, _SHIFT)


def _paste(img: np.ndarray, x0: int, y0: int, patch: np.ndarray, mask: np.ndarray) -> None:
    h, w = mask.shape[:2]
    cv2.copyTo(patch, mask, img[y0 : y0 + h, x0 : x0 + w])


def _blur_box(img: np.ndarray, x0: int, y0: int, x1: int, y1: int, streak: np.ndarray) -> None:
    img[y0:y1, x0:x1] = _streak(img[y0:y1, x0:x1], streak)


def _drawable_key(d: Drawable) -> tuple:
    """Everything about ``d`` that what it paints depends on, exactly (not rounded)."""
    return (
        d.shape,
        d.pose.tobytes(),
        np.asarray(d.size, dtype=float).tobytes(),
        tuple(d.color),
        d.marker,
        None if d.marker_pose is None else d.marker_pose.tobytes(),
        d.wall,
        None if d.velocity is None else np.asarray(d.velocity, dtype=float).tobytes(),
    )


def _noise_bank(
    rng: np.random.Generator, shape: tuple[int, ...], sigma: float
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Six images of sensor noise (``sigma`` grey levels), each as its positive and negative
    parts rounded to uint8; none when ``sigma`` is 0."""
    bank = []
    n = np.empty(shape)
    for _ in range(6 if sigma > 0 else 0):
        # The numbers rng.normal(0, sigma, shape) draws, into one buffer for all six.
        rng.standard_normal(out=n)
        n *= sigma
        # Rounded once (half to even, as a uint8 result rounds), then each sign saturated to
        # uint8 from the integers: clip(round(+-n), 0, 255) with one pass over the floats.
        rounded = cv2.add(n, 0.0, dtype=cv2.CV_16S)
        bank.append(
            (
                cv2.add(rounded, 0, dtype=cv2.CV_8U),
                # OpenCV takes a scalar for either operand; the stubs allow only arrays
                cv2.subtract(0, rounded, dtype=cv2.CV_8U),  # type: ignore[call-overload]
            )
        )
    return bank


@functools.lru_cache(maxsize=32)
def _fractions(n: int) -> np.ndarray:
    """``(n, 1, 1)`` steps 0, 1/n, ... along an edge."""
    return np.linspace(0, 1, n, endpoint=False)[:, None, None]


def _changed_box(a: np.ndarray, b: np.ndarray) -> tuple[int, int, int, int] | None:
    """The smallest box (x0, y0, x1, y1; pixels, x1 and y1 exclusive) holding every pixel in
    which the images ``a`` and ``b`` (H x W x C) differ; None when they are the same."""
    diff = cv2.absdiff(a, b)
    channels = diff.shape[2] if diff.ndim == 3 else 1
    # Channels side by side in one row: the box of the non-zero bytes, in bytes.
    x, y, w, h = cv2.boundingRect(diff.reshape(diff.shape[0], -1))
    if w == 0:
        return None
    return x // channels, y, (x + w - 1) // channels + 1, y + h


def _scene_key(cam_pose: np.ndarray, drawables: list[Drawable]) -> bytes:
    """Bytes that change whenever the camera or anything it could draw moves."""
    parts = [cam_pose.round(4).tobytes()]
    for d in drawables:
        parts.append(d.name.encode())
        parts.append(d.pose.round(4).tobytes())
        parts.append(np.asarray(d.size).round(4).tobytes())
        if d.velocity is not None:
            parts.append(np.asarray(d.velocity).round(3).tobytes())
    return b"".join(parts)


def _streak(img: np.ndarray, streak: np.ndarray) -> np.ndarray:
    """Average ``img`` along the pixel displacement ``streak`` (motion blur); unchanged below 1 px.

    Long streaks are drawn on a reduced copy (at most ``STREAK_PX`` pixels of
    streak) and scaled back, so the cost does not grow with the streak.
    """
    length = float(np.hypot(*streak))
    if length < 1.0:
        return img
    h, w = img.shape[:2]
    # Power-of-two reductions keep the resizing cheap.
    scale = float(2 ** max(0, math.ceil(math.log2(length / STREAK_PX))))
    small = img
    if scale > 1.0:
        size = (max(1, round(w / scale)), max(1, round(h / scale)))
        small = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
    kernel = _line_kernel(round(streak[0] / scale, 1), round(streak[1] / scale, 1))
    small = cv2.filter2D(small, -1, kernel, borderType=cv2.BORDER_REPLICATE)
    if scale > 1.0:
        return cv2.resize(small, (w, h), interpolation=cv2.INTER_LINEAR)
    return small


@functools.lru_cache(maxsize=512)
def _line_kernel(dx: float, dy: float) -> np.ndarray:
    """A normalised kernel averaging along the segment (-dx/2, -dy/2)..(dx/2, dy/2), pixels.

    Its shape is the segment's bounding box (odd sides), so a mostly horizontal
    or vertical streak costs little more than a one-dimensional filter.
    """
    nx = int(math.ceil(abs(dx))) | 1
    ny = int(math.ceil(abs(dy))) | 1
    kernel = np.zeros((ny, nx), np.float32)
    cx, cy = nx // 2, ny // 2
    steps = 2 * max(nx, ny) + 1
    for t in np.linspace(-0.5, 0.5, steps):
        x, y = int(round(cx + t * dx)), int(round(cy + t * dy))
        kernel[min(max(y, 0), ny - 1), min(max(x, 0), nx - 1)] += 1
    return kernel / kernel.sum()


def _clip_near(pc: np.ndarray) -> np.ndarray:
    """Clip a convex polygon in camera coordinates against the near plane (Sutherland-Hodgman)."""
    out = []
    n = len(pc)
    for i in range(n):
        a, b = pc[i], pc[(i + 1) % n]
        ina, inb = a[2] > NEAR, b[2] > NEAR
        if ina:
            out.append(a)
        if ina != inb:
            t = (NEAR + 1e-6 - a[2]) / (b[2] - a[2])
            out.append(a + t * (b - a))
    return np.array(out) if out else np.zeros((0, 3))


def _contains(d: Drawable, point: np.ndarray) -> bool:
    local = d.pose[:3, :3].T @ (point - d.pose[:3, 3])
    return bool(np.all(np.abs(local) <= 0.5 * np.asarray(d.size) + 1.0))


@dataclass(frozen=True)
class _Mesh:
    """A convex solid centred at the origin: vertices, faces, outward normals, face centres."""

    vertices: np.ndarray
    faces: tuple[tuple[int, ...], ...]
    normals: np.ndarray
    centres: np.ndarray


def _mesh(vertices: np.ndarray, faces: tuple[tuple[int, ...], ...]) -> _Mesh:
    centres = np.array([vertices[list(f)].mean(axis=0) for f in faces])
    normals = []
    for f, c in zip(faces, centres, strict=True):
        p = vertices[list(f)]
        n = np.cross(p[1] - p[0], p[2] - p[0])
        norm = np.linalg.norm(n)
        normals.append(n / norm if norm > 1e-12 else c / max(np.linalg.norm(c), 1e-12))
    return _Mesh(vertices, faces, np.array(normals), centres)


@functools.lru_cache(maxsize=256)
def _box_mesh(dx: float, dy: float, dz: float) -> _Mesh:
    """A box of those extents (mm)."""
    return _mesh(UNIT_BOX * [dx, dy, max(dz, 1e-3)], BOX_FACES)


@functools.lru_cache(maxsize=64)
def _cylinder_mesh(dx: float, dy: float, dz: float) -> _Mesh:
    """A 16-sided prism standing for a cylinder of those extents (mm)."""
    a = np.linspace(0, 2 * np.pi, CYLINDER_SIDES, endpoint=False)
    ring = np.column_stack([0.5 * dx * np.cos(a), 0.5 * dy * np.sin(a)])
    bottom = np.column_stack([ring, np.full(CYLINDER_SIDES, -0.5 * dz)])
    top = np.column_stack([ring, np.full(CYLINDER_SIDES, 0.5 * dz)])
    n = CYLINDER_SIDES
    faces = [tuple(range(n, 2 * n)), tuple(reversed(range(n)))]
    faces += [(i, (i + 1) % n, n + (i + 1) % n, n + i) for i in range(n)]
    return _mesh(np.vstack([bottom, top]), tuple(faces))
