"""The collision scene of a rig: table plane, obstacle boxes, triangle meshes, named places.

Built from a hardware profile (:meth:`Scene.from_profile`)::

    table: {z: -10}                     # the table top, mm in the arm's base frame (optional)
    obstacles:
      - box: {center: [250, 0, 60], size: [20, 300, 120], rpy: [0, 0, 15], name: wall}
      - mesh: {file: fixtures/bin.stl, position: [60, 230, 0], rpy: [0, 0, 90], scale: 1.0}
      - cylinder: {center: [0, 200, 50], radius: 20, height: 100}   # axis along z, or rpy
      - sphere: {center: [150, 150, 30], radius: 25}
      - table: {z: -10}                 # the same as the top-level key
    places: {garbage_bin: [60, 230, 40], ...}

The table plane is a half-space (everything below ``z`` is solid). A hardware
profile checked by :mod:`armtree.loader.profile` declares it with the top-level
``table: {z: MM}``; the ``- table:`` obstacle entry serves scenes given as plain
mappings. :func:`armtree.load_profile` builds this scene once while it validates,
so its errors (a mesh that fails to load, a place inside an obstacle) are found
by ``armtree check``, at the entry's file, line and column.

Units: mm and degrees. Mesh paths are relative to the profile's folder.
Cylinders and spheres are checked as closed polyhedra that contain them (a
24-sided prism, a 12 x 24 faceted ball), so a contact is never missed and a
near miss may be reported as a contact by at most a few percent of the radius. Every
place must lie outside every obstacle and above the table ("kept clear"),
otherwise :class:`~armtree.errors.ConfigError`.
"""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from armtree.errors import ConfigError

from .geometry import box_triangles, from_rpy_deg, transform
from .meshio import load_mesh

#: Obstacle kinds a profile may list (cylinders and spheres become enclosing meshes).
SHAPES = ("box", "cylinder", "sphere", "mesh", "table")


@dataclass(frozen=True)
class BoxObstacle:
    """An oriented box: ``center`` (mm), ``size`` (full edge lengths, mm), ``rotation`` 3x3."""

    name: str
    center: np.ndarray
    size: np.ndarray
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))

    def pose(self) -> np.ndarray:
        """The centre pose, 4x4 mm."""
        return transform(self.rotation, self.center)

    def contains(self, points: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Boolean ``(...)``: points ``(..., 3)`` mm strictly inside the box grown by ``margin``."""
        local = (np.asarray(points, dtype=float) - self.center) @ self.rotation
        return np.all(np.abs(local) < 0.5 * self.size + margin, axis=-1)


@dataclass(frozen=True)
class MeshObstacle:
    """A triangle mesh ``triangles`` ``(T, 3, 3)`` in the base frame (mm) and where it came from."""

    name: str
    triangles: np.ndarray
    source: str = ""

    @property
    def lower(self) -> np.ndarray:
        """Lower corner of the mesh's axis-aligned bounding box, mm."""
        return self.triangles.reshape(-1, 3).min(axis=0)

    @property
    def upper(self) -> np.ndarray:
        """Upper corner of the mesh's axis-aligned bounding box, mm."""
        return self.triangles.reshape(-1, 3).max(axis=0)

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Boolean ``(N,)``: points ``(N, 3)`` inside the mesh (ray parity; closed meshes)."""
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        t = self.triangles
        # Cast a ray along a skew direction so it rarely grazes an edge or a vertex.
        d = np.array([0.5773, 0.5774, 0.5773])
        e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        h = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, h)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = pts[:, None, :] - t[None, :, 0]
        u = np.einsum("ptj,tj->pt", s, h) * inv
        q = np.cross(s, e1[None])
        v = np.einsum("j,ptj->pt", d, q) * inv
        dist = np.einsum("tj,ptj->pt", e2, q) * inv
        hits = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (dist > 0)
        return (hits.sum(axis=1) % 2) == 1


class SceneSource(Protocol):
    """A loaded profile as a scene is read from it: its parsed YAML, its file and errors
    positioned at a dotted key (:class:`armtree.Profile` satisfies it; the maths layer
    sits below the loader, so it names only what it reads)."""

    @property
    def source(self) -> Path | None:
        """The profile's file."""
        ...

    @property
    def data(self) -> dict[str, Any]:
        """The profile's YAML as parsed (lengths in mm)."""
        ...

    def error(self, path: str, message: str) -> ConfigError:
        """A configuration error at the place ``path`` (``"obstacles.0.size"``) was written."""
        ...


@dataclass
class Scene:
    """Everything an arm must not touch, and the places that must stay reachable.

    ``table_z`` is the table top height (mm, base frame) or ``None`` for no table.
    ``places`` maps names to ``(3,)`` positions in mm.
    """

    table_z: float | None = None
    boxes: tuple[BoxObstacle, ...] = ()
    meshes: tuple[MeshObstacle, ...] = ()
    places: dict[str, np.ndarray] = field(default_factory=dict)
    source: str | None = None

    @classmethod
    def from_profile(
        cls, profile: SceneSource | Mapping[str, Any], base_dir: str | Path | None = None
    ) -> Scene:
        """The scene of a profile (a :class:`Profile` object or its plain mapping).

        Reads the ``table``, ``obstacles`` and ``places`` keys. Raises
        :class:`~armtree.errors.ConfigError` for malformed entries, degenerate
        boxes, meshes that fail to load and places inside an obstacle.
        """
        data, source = _profile_mapping(profile)
        fail = _Fail(profile)
        if base_dir is None:
            base_dir = Path(source).parent if source else Path.cwd()
        base_dir = Path(base_dir)
        table_z: float | None = None
        if data.get("table") is not None:
            table_z = _table(data["table"], fail, "table")
        boxes: list[BoxObstacle] = []
        meshes: list[MeshObstacle] = []
        obstacles = data.get("obstacles") or []
        if not isinstance(obstacles, Sequence) or isinstance(obstacles, str):
            raise fail("obstacles", "must be a list")
        for k, entry in enumerate(obstacles):
            where = f"obstacles.{k}"
            if not isinstance(entry, Mapping) or len(entry) != 1:
                raise fail(where, f"expected one shape ({', '.join(SHAPES)}), got {entry!r}")
            ((kind, spec),) = entry.items()
            at = f"{where}.{kind}"
            if kind == "box":
                boxes.append(_box(spec, fail, at, f"box{k}"))
            elif kind == "mesh":
                meshes.append(_mesh(spec, fail, at, base_dir, f"mesh{k}"))
            elif kind in ("cylinder", "sphere"):
                meshes.append(_solid(kind, spec, fail, at, f"{kind}{k}"))
            elif kind == "table":
                table_z = _table(spec, fail, at)
            else:
                raise fail(where, f"unknown obstacle kind {kind!r}; use one of {', '.join(SHAPES)}")
        places = {}
        for name, value in (data.get("places") or {}).items():
            places[str(name)] = _vector(value, fail, f"places.{name}", min_len=3)[:3]
        scene = cls(table_z, tuple(boxes), tuple(meshes), places, source)
        for name, p in places.items():
            blocker = scene.blocker_of(p)
            if blocker is not None:
                raise fail(f"places.{name}", _place_blocked(name, p, blocker))
        return scene

    def check_places(self) -> None:
        """Raise ConfigError if a named place is inside an obstacle or under the table."""
        for name, p in self.places.items():
            blocker = self.blocker_of(p)
            if blocker is not None:
                raise ConfigError(_place_blocked(name, p, blocker), file=self.source)

    def blocker_of(self, point: np.ndarray) -> str | None:
        """The name of the obstacle containing ``point`` (mm), ``"the table"``, or None."""
        p = np.asarray(point, dtype=float)
        if self.table_z is not None and p[2] < self.table_z - 1e-9:
            return "the table"
        for b in self.boxes:
            if b.contains(p):
                return f"obstacle {b.name!r}"
        for m in self.meshes:
            if np.all(p >= m.lower) and np.all(p <= m.upper) and m.contains(p[None])[0]:
                return f"mesh {m.name!r}"
        return None

    def fingerprint(self) -> str:
        """A hash of the geometry (table, boxes, meshes): equal scenes give equal strings."""
        h = hashlib.sha256()
        h.update(repr(self.table_z).encode())
        for b in self.boxes:
            for arr in (b.center, b.size, b.rotation):
                h.update(np.round(np.asarray(arr, dtype=float), 9).tobytes())
        for m in self.meshes:
            h.update(np.round(m.triangles, 9).tobytes())
        return h.hexdigest()

    def triangles(self) -> np.ndarray:
        """Every obstacle surface as triangles ``(T, 3, 3)`` mm (boxes triangulated, no table)."""
        parts = [box_triangles(b.pose(), b.size) for b in self.boxes]
        parts += [m.triangles for m in self.meshes]
        return np.concatenate(parts) if parts else np.zeros((0, 3, 3))


def _place_blocked(name: str, point: np.ndarray, blocker: str) -> str:
    return (
        f"place {name!r} at {np.round(point, 1).tolist()} mm is inside {blocker}: "
        "places must be kept clear of obstacles"
    )


def _profile_mapping(
    profile: SceneSource | Mapping[str, Any],
) -> tuple[Mapping[str, Any], str | None]:
    if isinstance(profile, Mapping):
        return profile, None
    return profile.data, str(profile.source) if profile.source else None


class _Fail:
    """Makes ConfigErrors at the position of a dotted profile path when the profile knows it."""

    def __init__(self, profile: SceneSource | Mapping[str, Any]) -> None:
        self.profile = profile

    def __call__(self, path: str, message: str) -> ConfigError:
        if isinstance(self.profile, Mapping):
            err = ConfigError(f"{path}: {message}")
        else:
            err = self.profile.error(path, message)  # it knows where the value was written
        # positioned by the dotted path; shown with list items as [i]
        err.message = re.sub(r"\.(\d+)(?=\.|$)", r"[\1]", path) + f": {message}"
        return err


def _vector(
    value: Any, fail: _Fail, where: str, min_len: int = 3, exact: bool = False
) -> np.ndarray:
    ok = isinstance(value, Sequence) and not isinstance(value, str)
    ok = ok and (len(value) == min_len if exact else len(value) >= min_len)
    ok = ok and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value
    )
    if not ok:
        n = f"exactly {min_len}" if exact else f"at least {min_len}"
        raise fail(where, f"expected a list of {n} finite numbers, got {value!r}")
    return np.array(value, dtype=float)


def _number(value: Any, fail: _Fail, where: str, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise fail(where, f"expected a finite number, got {value!r}")
    if positive and value <= 0:
        raise fail(where, f"must be > 0 mm, got {value!r} (degenerate)")
    return float(value)


def _table(spec: Any, fail: _Fail, where: str) -> float:
    if isinstance(spec, Mapping):
        if set(spec) != {"z"}:
            raise fail(where, f"expected {{z: MM}}, got {dict(spec)!r}")
        return _number(spec["z"], fail, f"{where}.z")
    return _number(spec, fail, where)


def _check_keys(spec: Any, allowed: set[str], required: set[str], fail: _Fail, where: str) -> None:
    if not isinstance(spec, Mapping):
        raise fail(where, f"expected a mapping, got {spec!r}")
    unknown = set(spec) - allowed
    if unknown:
        raise fail(where, f"unknown key(s) {sorted(unknown)}; allowed: {sorted(allowed)}")
    missing = required - set(spec)
    if missing:
        raise fail(where, f"missing {sorted(missing)}")


def _box(spec: Any, fail: _Fail, where: str, default_name: str) -> BoxObstacle:
    _check_keys(spec, {"center", "size", "rpy", "name"}, {"center", "size"}, fail, where)
    center = _vector(spec["center"], fail, f"{where}.center", exact=True)
    size = _vector(spec["size"], fail, f"{where}.size", exact=True)
    if np.any(size <= 0):
        raise fail(
            f"{where}.size", f"every edge must be > 0 mm, got {size.tolist()} (a degenerate box)"
        )
    rpy = _vector(spec.get("rpy", [0, 0, 0]), fail, f"{where}.rpy", exact=True)
    return BoxObstacle(str(spec.get("name", default_name)), center, size, from_rpy_deg(rpy))


def _prism(radius: float, height: float, sides: int = 24) -> np.ndarray:
    """A closed prism around the z axis that contains the cylinder (radius, height), centred."""
    # Circumscribed: the flat faces touch the cylinder, so no contact is ever missed.
    r = radius / np.cos(np.pi / sides)
    a = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    ring = np.stack([r * np.cos(a), r * np.sin(a), np.zeros(sides)], axis=1)
    lo, hi = ring - [0, 0, height / 2], ring + [0, 0, height / 2]
    nxt = np.roll(np.arange(sides), -1)
    c_lo, c_hi = np.array([0, 0, -height / 2]), np.array([0, 0, height / 2])
    tris = []
    for i, j in zip(range(sides), nxt, strict=True):
        tris += [
            [lo[i], lo[j], hi[j]],
            [lo[i], hi[j], hi[i]],
            [c_lo, lo[j], lo[i]],
            [c_hi, hi[i], hi[j]],
        ]
    return np.array(tris)


def _ball(radius: float, rings: int = 12, sectors: int = 24) -> np.ndarray:
    """A closed polyhedron that contains the sphere of ``radius`` (vertices pushed outward)."""
    # Inflating by the worst face-to-sphere gap keeps every face outside the sphere.
    r = radius / (np.cos(np.pi / sectors) * np.cos(np.pi / (2 * rings)))
    th = np.linspace(0.0, np.pi, rings + 1)
    ph = np.linspace(0.0, 2 * np.pi, sectors + 1)
    v = r * np.stack(
        [
            np.outer(np.sin(th), np.cos(ph)),
            np.outer(np.sin(th), np.sin(ph)),
            np.outer(np.cos(th), np.ones_like(ph)),
        ],
        axis=-1,
    )
    tris = []
    for i in range(rings):
        for j in range(sectors):
            a, b, c, d = v[i, j], v[i + 1, j], v[i + 1, j + 1], v[i, j + 1]
            if i > 0:
                tris.append([a, b, d])
            if i < rings - 1:
                tris.append([b, c, d])
    return np.array(tris)


def _solid(kind: str, spec: Any, fail: _Fail, where: str, default_name: str) -> MeshObstacle:
    keys = {"center", "radius", "name"} | ({"height", "rpy"} if kind == "cylinder" else set())
    _check_keys(spec, keys, keys - {"name", "rpy"}, fail, where)
    center = _vector(spec["center"], fail, f"{where}.center", exact=True)
    radius = _number(spec["radius"], fail, f"{where}.radius", positive=True)
    if kind == "cylinder":
        height = _number(spec["height"], fail, f"{where}.height", positive=True)
        rot = from_rpy_deg(_vector(spec.get("rpy", [0, 0, 0]), fail, f"{where}.rpy", exact=True))
        tris = _prism(radius, height) @ rot.T + center
    else:
        tris = _ball(radius) + center
    return MeshObstacle(str(spec.get("name", default_name)), tris, kind)


def _mesh(spec: Any, fail: _Fail, where: str, base_dir: Path, default_name: str) -> MeshObstacle:
    _check_keys(spec, {"file", "position", "rpy", "scale", "name"}, {"file"}, fail, where)
    if not isinstance(spec["file"], str) or not spec["file"]:
        raise fail(f"{where}.file", "expected a path")
    path = Path(spec["file"]).expanduser()
    if not path.is_absolute():
        path = base_dir / path
    scale = _number(spec.get("scale", 1.0), fail, f"{where}.scale", positive=True)
    position = _vector(spec.get("position", [0, 0, 0]), fail, f"{where}.position", exact=True)
    rotation = from_rpy_deg(_vector(spec.get("rpy", [0, 0, 0]), fail, f"{where}.rpy", exact=True))
    try:
        tris = load_mesh(path) * scale @ rotation.T + position
    except ConfigError as exc:
        # Point at the profile's entry; the message keeps the mesh file's path.
        shown = str(path)
        raise fail(
            f"{where}.file", exc.message if shown in exc.message else f"{shown}: {exc.message}"
        ) from None
    area2 = np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    extent = float(np.ptp(tris.reshape(-1, 3), axis=0).max())
    # Zero-area slivers carry no surface of their own; drop them, but refuse a mesh of nothing.
    tris = tris[area2 > 1e-12 * max(extent, 1.0) ** 2]
    if len(tris) == 0:
        raise fail(f"{where}.file", f"every triangle of {path} is degenerate (zero area)")
    return MeshObstacle(str(spec.get("name", default_name)), tris, str(path))
