"""What the layers below the loader see of a loaded profile and a loaded tree.

:class:`armtree.Profile` and :class:`armtree.Tree` live in the loader, above this layer;
the rig, the component factories' context and the sweep hold them, so they are typed
by these protocols, which both classes satisfy. A plugin may name either the protocol or
the class.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any, Protocol

import py_trees

from armtree.errors import ConfigError, Mark


class RegisteredComponent(Protocol):
    """One component a plugin registered: its ``factory`` is the plugin's own class or
    function (an arm, camera, tracker, planner, predicate or command), so it is typed by
    nothing more than what its kind's hook specification asks of it."""

    @property
    def factory(self) -> Any:
        """The registered class or function."""
        ...


class ComponentLookup(Protocol):
    """The registered components as the layers below the plugin manager look them up
    (:class:`armtree.hooks.plugin_manager.Registry` satisfies it)."""

    def has(self, kind: str, name: str) -> bool:
        """True when a component of ``kind`` is registered as ``name``."""
        ...

    def get(self, kind: str, name: str, where: Mark | None = None) -> RegisteredComponent:
        """The component ``name`` of ``kind``; a :class:`ConfigError` at ``where`` if none."""
        ...

    def instances(self, kind: str, reserved: Iterable[str] = ()) -> dict[str, Any]:
        """Every registered ``kind`` by name; a name in ``reserved`` is refused."""
        ...


class ProfileView(Protocol):
    """A loaded hardware profile: its name, file, parsed data and where each key was written.

    ``data`` is the profile's YAML as parsed (plain dicts, lists and scalars; lengths in
    mm, angles in degrees), so its values are whatever the file says.
    """

    name: str
    source: Path | None
    data: dict[str, Any]

    @property
    def registry(self) -> ComponentLookup:
        """The components of the plugins it was loaded with."""
        ...

    def mark(self, path: str) -> Mark | None:
        """Where a dotted key (``"arm.port"``) was written, if known."""
        ...

    def error(self, path: str, message: str) -> ConfigError:
        """A configuration error pointing at that key's place in the file."""
        ...

    def section(self, name: str) -> dict[str, Any] | None:
        """A top-level section (``"workcell"``), None when the profile has none."""
        ...

    def component(self, section: str) -> dict[str, Any] | None:
        """A component's configuration (``"arm"``) with its ``type`` resolved, or None."""
        ...


class TreeView(Protocol):
    """A loaded behaviour tree: its name, root node, file, tick rate and the profile it
    was checked against (None when loaded without one)."""

    name: str
    root: py_trees.behaviour.Behaviour
    source: Path | None
    tick_hz: float

    @property
    def profile(self) -> ProfileView | None:
        """The profile the tree was loaded against."""
        ...

    @property
    def registry(self) -> ComponentLookup:
        """The components of the plugins it was loaded with."""
        ...
