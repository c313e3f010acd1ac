"""Reading a profile that may be a :class:`~armtree.loader.profile.Profile` or a mapping.

Components, the workcell and the calibration section are handed the loaded
``Profile``; tests and embedding code may hand them a plain mapping. These three
accessors read either, so what reads a profile needs nothing from the module that
loads one.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, Protocol

from armtree.errors import ConfigError


class LoadedProfile(Protocol):
    """What these accessors read of a loaded :class:`~armtree.loader.profile.Profile`
    (a layer above this one): its data, its file, errors at a value's position, and a
    component's section with its declared defaults."""

    @property
    def data(self) -> Mapping[str, Any]: ...

    @property
    def source(self) -> Path | None: ...

    def error(self, path: str, message: str) -> ConfigError: ...

    def component(self, key: str) -> Any: ...


#: A profile as its readers take it: loaded, or a plain mapping (tests, embedding code).
AnyProfile = LoadedProfile | Mapping[str, Any]


def profile_section(profile: AnyProfile | None, key: str, default: Any = None) -> Any:
    """Top-level section ``key`` of a :class:`Profile` or of a plain profile mapping.

    Components receive the Profile; tests and embedding code may pass a mapping
    (or an object with the section as an attribute). ``default`` when absent.
    """
    if profile is None:
        return default
    data = getattr(profile, "data", profile)
    if isinstance(data, Mapping):
        return data.get(key, default)
    return getattr(profile, key, default)


def profile_source(profile: AnyProfile | None) -> str | None:
    """The file a :class:`Profile` was loaded from, as a string; ``None`` when unknown.

    Plain profile mappings (tests, embedding code) have no file.
    """
    source = getattr(profile, "source", None)
    return str(source) if source else None


def profile_error(profile: AnyProfile | None, path: str, message: str) -> ConfigError:
    """A :class:`ConfigError` ``"PATH: MESSAGE"`` about the value at dotted ``path``.

    A :class:`~armtree.loader.profile.Profile` places it at the value's file, line and column
    (:meth:`Profile.error`); a plain mapping gives one naming no file.
    """
    error = getattr(profile, "error", None)
    if callable(error) and not isinstance(profile, Mapping):
        return error(path, message)
    return ConfigError(f"{path}: {message}", file=profile_source(profile))


def component_config(profile: AnyProfile | None, key: str) -> Any:
    """A component's config with declared defaults filled in when the Profile offers that."""
    component = getattr(profile, "component", None)
    if callable(component):
        return component(key)
    return profile_section(profile, key)
