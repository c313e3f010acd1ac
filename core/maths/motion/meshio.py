"""Triangle meshes from STL (ASCII and binary) and Wavefront OBJ files.

Every loader returns ``(T, 3, 3)`` float triangles in the file's units (armtree
takes them as mm). A file that cannot be read or parsed raises
:class:`~armtree.errors.ConfigError` naming the file and, for text formats, the line.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from armtree.errors import ConfigError


def load_mesh(path: str | Path) -> np.ndarray:
    """Triangles ``(T, 3, 3)`` from an ``.stl`` or ``.obj`` file; ConfigError if it fails."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"mesh file {str(path)!r} does not exist", file=str(path))
    suffix = path.suffix.lower()
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ConfigError(f"cannot read mesh file: {exc}", file=str(path)) from exc
    if suffix == ".stl":
        tris = _stl(data, str(path))
    elif suffix == ".obj":
        tris = _obj(data, str(path))
    else:
        raise ConfigError(
            f"unsupported mesh format {suffix or '(none)'!r}; use .stl or .obj", file=str(path)
        )
    if len(tris) == 0:
        raise ConfigError("mesh has no triangles", file=str(path))
    if not np.all(np.isfinite(tris)):
        raise ConfigError("mesh has non-finite vertex coordinates", file=str(path))
    return tris


def _stl(data: bytes, name: str) -> np.ndarray:
    if len(data) >= 84:
        (count,) = struct.unpack_from("<I", data, 80)
        # A binary STL is exactly header + count + 50 bytes per facet; ASCII files that
        # happen to start with "solid" are told apart by that length, not the word.
        if len(data) == 84 + 50 * count:
            rec = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
            return np.frombuffer(data, dtype=rec, count=count, offset=84)["v"].astype(float)
    try:
        text = data.decode("ascii")
    except UnicodeDecodeError:
        raise ConfigError(
            "not a valid STL file: binary length does not match its facet count "
            "and it is not ASCII",
            file=name,
        ) from None
    if not text.lstrip().startswith("solid"):
        raise ConfigError("not a valid STL file (no 'solid' header)", file=name, line=1)
    verts: list[list[float]] = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        parts = line.split()
        if parts and parts[0] == "vertex":
            try:
                if len(parts) != 4:
                    raise ValueError
                verts.append([float(p) for p in parts[1:]])
            except ValueError:
                raise ConfigError(
                    f"bad vertex line {line.strip()!r}", file=name, line=lineno
                ) from None
    if len(verts) % 3:
        raise ConfigError(f"{len(verts)} vertices is not a whole number of facets", file=name)
    return np.array(verts, dtype=float).reshape(-1, 3, 3)


def _obj(data: bytes, name: str) -> np.ndarray:
    text = data.decode("utf-8", errors="replace")
    verts: list[list[float]] = []
    faces: list[tuple[int, list[int]]] = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        parts = line.split("#", 1)[0].split()
        if not parts:
            continue
        try:
            if parts[0] == "v":
                verts.append([float(p) for p in parts[1:4]])
                if len(parts) < 4:
                    raise ValueError
            elif parts[0] == "f":
                idx = [int(p.split("/")[0]) for p in parts[1:]]
                if len(idx) < 3 or 0 in idx:
                    raise ValueError
                faces.append((lineno, [i - 1 if i > 0 else len(verts) + i for i in idx]))
        except ValueError:
            raise ConfigError(f"bad OBJ line {line.strip()!r}", file=name, line=lineno) from None
    v = np.array(verts, dtype=float).reshape(-1, 3)
    tris: list[NDArray[np.float64]] = []
    for lineno, idx in faces:
        if min(idx) < 0 or max(idx) >= len(v):
            raise ConfigError("face refers to a vertex that does not exist", file=name, line=lineno)
        # Polygons are split into a fan of triangles around their first vertex.
        tris.extend(v[[idx[0], idx[k], idx[k + 1]]] for k in range(1, len(idx) - 1))
    return np.array(tris, dtype=float).reshape(-1, 3, 3)


def write_stl_ascii(path: str | Path, triangles: np.ndarray, name: str = "mesh") -> None:
    """Write triangles ``(T, 3, 3)`` as an ASCII STL (normals from the vertex order)."""
    lines = [f"solid {name}"]
    for t in np.asarray(triangles, dtype=float):
        n = np.cross(t[1] - t[0], t[2] - t[0])
        n = n / (np.linalg.norm(n) or 1.0)
        lines.append(f"  facet normal {n[0]:.6e} {n[1]:.6e} {n[2]:.6e}")
        lines.append("    outer loop")
        lines.extend(f"      vertex {v[0]:.9e} {v[1]:.9e} {v[2]:.9e}" for v in t)
        lines.append("    endloop")
        lines.append("  endfacet")
    lines.append(f"endsolid {name}")
    Path(path).write_text("\n".join(lines) + "\n")


def write_stl_binary(path: str | Path, triangles: np.ndarray) -> None:
    """Write triangles ``(T, 3, 3)`` as a binary STL."""
    t = np.asarray(triangles, dtype=float)
    rec = np.zeros(len(t), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rec["v"] = t
    rec["n"] = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    Path(path).write_bytes(b"\0" * 80 + struct.pack("<I", len(t)) + rec.tobytes())
