"""Small readers of a profile's ``world:`` entries that point errors at the entry.

``_Errors(profile)(("world", "objects", name), message)`` is a ConfigError at
that entry's file, line and column; :func:`_number`, :func:`_vector` and
:func:`_mapping` read one value or refuse it there. The world section's parser
and the randomize parser share them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from armtree.config.profile_access import profile_error
from armtree.errors import ConfigError, did_you_mean, shown
from armtree.loader.profile import Profile


class _Errors:
    """Builds ConfigErrors that name the entry and point into the profile."""

    def __init__(self, profile: Profile) -> None:
        self.profile = profile

    def __call__(self, path: tuple[Any, ...], message: str) -> ConfigError:
        return profile_error(self.profile, ".".join(str(p) for p in path), message)


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


def _mapping(
    err: _Errors, path: tuple[Any, ...], value: Any, keys: Sequence[str]
) -> Mapping[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise err(path, f"expected a mapping, got {value!r}")
    for key in value:
        if key not in keys:
            hint = did_you_mean(str(key), keys, list_up_to=len(keys))
            raise err((*path, key), f"unknown key {key!r}{hint}")
    return value
