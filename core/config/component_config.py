"""Checking a component's profile section (``camera:``, ``tracker:``, ...) against its PARAMS.

Shared by every component kind, so that cameras, trackers and the others report a
bad key or value the same way: the dotted path, the file, line and column, a
did-you-mean for an unknown key.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from armtree.config.profile_access import profile_error
from armtree.errors import ConfigError, did_you_mean

from .params import Param, check_value


def config_error(where: Any, path: str, message: str) -> ConfigError:
    """A :class:`ConfigError` about the value at dotted ``path`` (``tracker.size_mm``).

    ``where`` is a loaded Profile (its ``error()`` gives the file, line and
    column the value was written at), a file name, or None.
    """
    if isinstance(where, (str, Path)):
        return ConfigError(f"{path}: {message}", file=str(where))
    return profile_error(where, path, message)


def check_config(
    config: Any, params: tuple[Param, ...], section: str, where: Any = None
) -> dict[str, Any]:
    """A component's mapping checked against its PARAMS, defaults filled in.

    ``type`` (the registry key) is ignored; an unknown key gets a did-you-mean,
    a wrong type names the key. Raises :class:`ConfigError` (see :func:`config_error`).
    """
    if config is None:
        config = {}
    if not isinstance(config, Mapping):
        raise config_error(where, f"{section}", f"expected a mapping, got {config!r}")
    known = {p.name: p for p in params}
    values = {p.name: p.default for p in params}
    for key, value in config.items():
        if key == "type":
            continue
        if key not in known:
            hint = did_you_mean(str(key), known, list_up_to=len(known))
            raise config_error(where, f"{section}", f"unknown key {key!r}{hint}")
        if value is None and known[key].default is None:
            values[key] = None
            continue
        try:
            values[key] = check_value(known[key], value)
        except ValueError as exc:
            raise config_error(where, f"{section}.{key}", f"{exc}") from None
    return values
