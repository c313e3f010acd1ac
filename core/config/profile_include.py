"""``include:``: files laid over a hardware profile, such as what calibration measured.

A profile names the files with ``include: FILE`` or ``include: [FILE, ...]``
(``--set include=FILE`` works too). Each is a YAML mapping of profile sections
(``camera:``, ``arm:``, ``calibration:``, ...), found as a profile's other files
are: beside the profile first, then in the working directory. Their sections are
laid over the profile's own in order, mapping by mapping; any other value, a list
among them, replaces the one before it, so ``camera: {extrinsics: ...}`` replaces
the profile's camera pose and keeps its other keys. ``--set`` overrides still
come last. Values keep the position they were written at, so an error in an
included file names that file, line and column.

An included file may not name ``profile``, ``description``, ``plugins`` or
``include`` (one level of files, no cycles to follow).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from armtree.errors import ConfigError, shown

from .yamlio import MarkedDict, MarkedList, error_at, load_yaml_file

#: Top-level keys an included file may not set.
NOT_INCLUDED = ("profile", "description", "plugins", "include")


def include_specs(data: MarkedDict, errors: list[ConfigError]) -> list[tuple[str, Any]]:
    """The files ``data['include']`` names, with where each was written."""
    value = data.get("include")
    if value is None:
        return []
    where = data.value_mark("include")
    if isinstance(value, str):
        return [(value, where)]
    if isinstance(value, list) and all(isinstance(v, str) for v in value):
        marks = value.item_mark if isinstance(value, MarkedList) else (lambda i: where)
        return [(v, marks(i)) for i, v in enumerate(value)]
    errors.append(error_at("include: expected a file name or a list of file names", where))
    return []


def find_include(spec: str, source: Path | None) -> Path | None:
    """The file ``spec`` names: absolute, beside the profile ``source``, else in the
    working directory; None when there is none."""
    path = Path(spec)
    if path.is_absolute():
        return path if path.is_file() else None
    for folder in ([source.parent] if source is not None else []) + [Path.cwd()]:
        if (folder / path).is_file():
            return folder / path
    return None


def apply_includes(data: MarkedDict, source: Path | None, errors: list[ConfigError]) -> None:
    """Lay every file ``data`` includes over it, in order; problems go to ``errors``."""
    for spec, where in include_specs(data, errors):
        path = find_include(spec, source)
        if path is None:
            beside = f" beside {source.name} or" if source is not None else ""
            errors.append(
                error_at(f"include: no file {shown(spec)}{beside} in the working directory", where)
            )
            continue
        try:
            layer = load_yaml_file(path)
        except ConfigError as exc:
            errors.append(exc)
            continue
        if layer is None:
            continue
        if not isinstance(layer, MarkedDict):
            errors.append(
                error_at("an included file must be a mapping of profile sections", None, str(path))
            )
            continue
        for key in NOT_INCLUDED:
            if key in layer:
                errors.append(
                    error_at(
                        f"{key}: an included file may not set it (write it in the profile)",
                        layer.key_mark(key),
                    )
                )
                del layer[key]
        lay_over(data, layer)


def lay_over(base: MarkedDict, layer: MarkedDict) -> None:
    """Merge ``layer`` into ``base``: mappings key by key, anything else replaced."""
    for key, value in layer.items():
        old = base.get(key)
        if isinstance(old, MarkedDict) and isinstance(value, MarkedDict):
            lay_over(old, value)
            continue
        base[key] = value
        base.key_marks[key] = layer.key_mark(key)  # type: ignore[assignment]
        base.value_marks[key] = layer.value_mark(key)  # type: ignore[assignment]


__all__ = ["NOT_INCLUDED", "apply_includes", "find_include", "include_specs", "lay_over"]
