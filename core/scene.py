"""The collision scene of a rig: table plane, obstacle boxes, triangle meshes, named places.

Built from a hardware profile (:meth:`Scene.from_profile`)::

    table: {z: -10}                     # the table top, mm in the arm's base frame (optional)
    obstacles:
      - box: {center: [250, 0, 60], size: [20, 300, 120], rpy: [0, 0, 15], name: wall}
      - mesh: {file: fixtures/bin.stl, position: [60, 230, 0], rpy: [0, 0, 90], scale: 1.0}
      - table: {z: -10}                 # the same as the top-level key
    places: {garbage_bin: [60, 230, 40], ...}

Units: mm and degrees. Mesh paths are relative to the profile's folder. Every
place must lie outside every obstacle and above the table ("kept clear"),
otherwise :class:`~armtree.errors.ConfigError`.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .errors import ConfigError
from .geometry import box_triangles, from_rpy_deg, transform
from .meshio import load_mesh


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
    def from_profile(cls, profile: Any, base_dir: str | Path | None = None) -> Scene:
        """The scene of a profile (a :class:`Profile` object or its plain mapping).

        Reads the ``table``, ``obstacles`` and ``places`` keys. Raises
        :class:`~armtree.errors.ConfigError` for malformed entries, degenerate
        boxes, meshes that fail to load and places inside an obstacle.
        """
        data, source = _profile_mapping(profile)
        if base_dir is None:
            base_dir = Path(source).parent if source else Path.cwd()
        base_dir = Path(base_dir)
        table_z: float | None = None
        if data.get("table") is not None:
            table_z = _table(data["table"], source, "table")
        boxes: list[BoxObstacle] = []
        meshes: list[MeshObstacle] = []
        obstacles = data.get("obstacles") or []
        if not isinstance(obstacles, Sequence) or isinstance(obstacles, str):
            raise ConfigError("'obstacles' must be a list", file=source)
        for k, entry in enumerate(obstacles):
            where = f"obstacles[{k}]"
            if not isinstance(entry, Mapping) or len(entry) != 1:
                raise ConfigError(
                    f"{where}: expected one of {{box: ...}}, {{mesh: ...}}, {{table: ...}}",
                    file=source,
                )
            ((kind, spec),) = entry.items()
            if kind == "box":
                boxes.append(_box(spec, source, where, f"box{k}"))
            elif kind == "mesh":
                meshes.append(_mesh(spec, source, where, base_dir, f"mesh{k}"))
            elif kind in ("table", "plane"):
                table_z = _table(spec, source, where)
            else:
                raise ConfigError(
                    f"{where}: unknown obstacle kind {kind!r}; use box, mesh or table", file=source
                )
        places = {}
        for name, value in (data.get("places") or {}).items():
            places[str(name)] = _vector(value, source, f"places.{name}", min_len=3)[:3]
        scene = cls(table_z, tuple(boxes), tuple(meshes), places, source)
        scene.check_places()
        return scene

    def check_places(self) -> None:
        """Raise ConfigError if a named place is inside an obstacle or under the table."""
        for name, p in self.places.items():
            blocker = self.blocker_of(p)
            if blocker is not None:
                raise ConfigError(
                    f"place {name!r} at {np.round(p, 1).tolist()} mm is inside {blocker}: "
                    "places must be kept clear of obstacles",
                    file=self.source,
                )

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


def _profile_mapping(profile: Any) -> tuple[Mapping[str, Any], str | None]:
    source = None
    for attr in ("path", "file", "source"):
        value = getattr(profile, attr, None)
        if isinstance(value, (str, Path)):
            source = str(value)
            break
    if isinstance(profile, Mapping):
        return profile, source
    for attr in ("data", "raw", "mapping"):
        value = getattr(profile, attr, None)
        if isinstance(value, Mapping):
            return value, source
    return {
        key: getattr(profile, key)
        for key in ("table", "obstacles", "places")
        if hasattr(profile, key)
    }, source


def _vector(
    value: Any, source: str | None, where: str, min_len: int = 3, exact: bool = False
) -> np.ndarray:
    ok = isinstance(value, Sequence) and not isinstance(value, str)
    ok = ok and (len(value) == min_len if exact else len(value) >= min_len)
    ok = ok and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value
    )
    if not ok:
        n = f"exactly {min_len}" if exact else f"at least {min_len}"
        raise ConfigError(
            f"{where}: expected a list of {n} finite numbers, got {value!r}", file=source
        )
    return np.array(value, dtype=float)


def _number(value: Any, source: str | None, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{where}: expected a finite number, got {value!r}", file=source)
    return float(value)


def _table(spec: Any, source: str | None, where: str) -> float:
    if isinstance(spec, Mapping):
        unknown = set(spec) - {"z"}
        if unknown or "z" not in spec:
            raise ConfigError(f"{where}: expected {{z: MM}}, got {dict(spec)!r}", file=source)
        return _number(spec["z"], source, f"{where}.z")
    return _number(spec, source, where)


def _check_keys(
    spec: Any, allowed: set[str], required: set[str], source: str | None, where: str
) -> None:
    if not isinstance(spec, Mapping):
        raise ConfigError(f"{where}: expected a mapping, got {spec!r}", file=source)
    unknown = set(spec) - allowed
    if unknown:
        raise ConfigError(
            f"{where}: unknown key(s) {sorted(unknown)}; allowed: {sorted(allowed)}", file=source
        )
    missing = required - set(spec)
    if missing:
        raise ConfigError(f"{where}: missing {sorted(missing)}", file=source)


def _box(spec: Any, source: str | None, where: str, default_name: str) -> BoxObstacle:
    _check_keys(spec, {"center", "size", "rpy", "name"}, {"center", "size"}, source, where)
    center = _vector(spec["center"], source, f"{where}.center", exact=True)
    size = _vector(spec["size"], source, f"{where}.size", exact=True)
    if np.any(size <= 0):
        raise ConfigError(
            f"{where}.size: every edge must be > 0 mm, got {size.tolist()} (a degenerate box)",
            file=source,
        )
    rpy = _vector(spec.get("rpy", [0, 0, 0]), source, f"{where}.rpy", exact=True)
    return BoxObstacle(str(spec.get("name", default_name)), center, size, from_rpy_deg(rpy))


def _mesh(
    spec: Any, source: str | None, where: str, base_dir: Path, default_name: str
) -> MeshObstacle:
    _check_keys(spec, {"file", "position", "rpy", "scale", "name"}, {"file"}, source, where)
    if not isinstance(spec["file"], str) or not spec["file"]:
        raise ConfigError(f"{where}.file: expected a path", file=source)
    path = Path(spec["file"]).expanduser()
    if not path.is_absolute():
        path = base_dir / path
    scale = _number(spec.get("scale", 1.0), source, f"{where}.scale")
    if scale <= 0:
        raise ConfigError(f"{where}.scale: must be > 0, got {scale}", file=source)
    position = _vector(spec.get("position", [0, 0, 0]), source, f"{where}.position", exact=True)
    rotation = from_rpy_deg(_vector(spec.get("rpy", [0, 0, 0]), source, f"{where}.rpy", exact=True))
    tris = load_mesh(path) * scale @ rotation.T + position
    area2 = np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    extent = float(np.ptp(tris.reshape(-1, 3), axis=0).max())
    # Zero-area slivers carry no surface of their own; drop them, but refuse a mesh of nothing.
    tris = tris[area2 > 1e-12 * max(extent, 1.0) ** 2]
    if len(tris) == 0:
        raise ConfigError(
            f"{where}: every triangle of the mesh is degenerate (zero area)", file=str(path)
        )
    return MeshObstacle(str(spec.get("name", default_name)), tris, str(path))
