"""Recording places into a profile YAML file with its comments and layout kept.

:func:`record_place` sets ``places.NAME: [x, y, z]`` (mm, one decimal) with
ruamel.yaml's round-trip loader and dumper, so every other line of the file,
its comments included, is written back as it was. An existing place keeps its
position in the file and its end-of-line comment.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from armtree.errors import ConfigError

#: A place name a tree can refer to.
NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def record_place(path: str | Path, name: str, xyz: Sequence[float]) -> None:
    """Write ``places.name = xyz`` (mm) into the profile at ``path``, keeping the rest."""
    from ruamel.yaml import YAML
    from ruamel.yaml.comments import CommentedMap, CommentedSeq

    if not NAME.match(name):
        raise ConfigError(
            f"place name {name!r}: use letters, digits and _ (not first a digit)", file=str(path)
        )
    path = Path(path)
    text = path.read_text()
    yaml = YAML()  # round-trip: comments, key order, flow style and quotes are kept
    yaml.preserve_quotes = True
    yaml.width = 4096
    offset = dash_offset(text)
    yaml.indent(mapping=2, sequence=offset + 2, offset=offset)
    data = yaml.load(text)
    if not isinstance(data, CommentedMap):
        raise ConfigError("a profile is a mapping of sections", file=str(path))
    places = data.get("places")
    if places is None:
        places = CommentedMap()
        data["places"] = places
    elif not isinstance(places, CommentedMap):
        raise ConfigError("places: expected a mapping of name: [x, y, z]", file=str(path))
    value = CommentedSeq(round(float(v), 1) for v in xyz)
    value.fa.set_flow_style()
    places[name] = value
    with path.open("w") as out:
        yaml.dump(data, out)


def dash_offset(text: str) -> int:
    """How far this file indents a block list's ``-`` under its key (2 when it has none)."""
    key_indent = None
    for line in text.splitlines():
        stripped = line.lstrip(" ")
        if not stripped or stripped.startswith("#"):
            continue
        indent = len(line) - len(stripped)
        if stripped.startswith("- ") and key_indent is not None:
            return max(0, indent - key_indent)
        key_indent = indent if re.match(r"^[^#]*:\s*(#.*)?$", stripped) else None
    return 2


__all__ = ["NAME", "dash_offset", "record_place"]
