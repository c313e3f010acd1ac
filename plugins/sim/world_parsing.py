"""Pointing errors about a profile's ``world:`` at the entry.

:func:`check_section` checks a section against its declaration (``world_spec.WORLD``)
with every value marked where the profile wrote it, so each problem names its
file, line and column (or its ``--set`` option). ``_Errors(profile)(("world",
"objects", name), message)`` is a ConfigError at that entry, for the checks that
need the whole scene; :func:`_vector` reads a point of the profile's
``obstacles:`` or refuses it there.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from armtree.config.profile_access import AnyProfile, profile_error, profile_section, profile_source
from armtree.config.spec import Context, Spec
from armtree.config.yamlio import MarkedDict, MarkedList, error_at
from armtree.errors import ConfigError, Mark, shown
from armtree.loader.profile import Profile


class _Errors:
    """Builds ConfigErrors that name the entry and point into the profile."""

    def __init__(self, profile: Profile) -> None:
        self.profile = profile

    def __call__(self, path: tuple[Any, ...], message: str) -> ConfigError:
        return profile_error(self.profile, ".".join(str(p) for p in path), message)


@dataclass
class _ProfileContext(Context):
    """A spec's context whose errors without a position still name the profile's file."""

    file: str | None = None

    def add(self, message: str, mark: Mark | None) -> None:
        self.errors.append(error_at(message, mark, self.file))


def check_section(profile: AnyProfile, name: str, spec: Spec) -> list[ConfigError]:
    """Every problem ``spec`` finds in the profile's section ``name`` (none when it is
    absent), each at the file, line and column the profile wrote it (a :class:`Profile`)
    or naming no file (a plain mapping, as tests pass)."""
    value = profile_section(profile, name)
    if value is None:
        return []
    where = getattr(profile, "mark", None)
    locate: Callable[[str], Mark | None] = (
        where if callable(where) and not isinstance(profile, Mapping) else lambda path: None
    )
    data = getattr(profile, "data", profile)
    file = profile_source(profile) or getattr(profile, "name", None)
    ctx = _ProfileContext(data if isinstance(data, Mapping) else {}, file=file)
    spec.check(_marked(value, name, locate), name, locate(name), ctx)
    return ctx.errors


def _marked(value: Any, path: str, locate: Callable[[str], Mark | None]) -> Any:
    """``value`` as marked containers, each entry at ``locate(its dotted path)``: a loaded
    profile keeps its marks by path, and the spec reads them from the containers."""
    if isinstance(value, Mapping):
        out = MarkedDict(mark=locate(path))
        for key, item in value.items():
            out[key] = _marked(item, f"{path}.{key}", locate)
            mark = locate(f"{path}.{key}")
            if mark is not None:
                out.key_marks[key] = out.value_marks[key] = mark
        return out
    if isinstance(value, list):
        items = MarkedList(
            [_marked(v, f"{path}.{i}", locate) for i, v in enumerate(value)], mark=locate(path)
        )
        items.item_marks = [locate(f"{path}.{i}") for i in range(len(value))]
        return items
    return value


def collected(errors: list[ConfigError]) -> ConfigError:
    """One ConfigError carrying every one of ``errors`` (``str()`` lists them all)."""
    first = errors[0]
    return ConfigError(first.message, first.file, first.line, first.column, errors=errors)


def _number(err: _Errors, path: tuple[Any, ...], value: Any, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not -1e300 < value < 1e300:
        raise err(path, f"expected a number, got {shown(value)}")
    if positive and value <= 0:
        raise err(path, f"must be positive, got {value!r}")
    return float(value)


def _vector(
    err: _Errors, path: tuple[Any, ...], value: Any, lengths: tuple[int, ...]
) -> list[float]:
    if (
        isinstance(value, (str, bytes))
        or not isinstance(value, Sequence)
        or len(value) not in lengths
    ):
        want = " or ".join(str(n) for n in lengths)
        raise err(path, f"expected a list of {want} numbers, got {value!r}")
    return [_number(err, path, v) for v in value]
