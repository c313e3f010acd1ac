"""What the loader reads off a component plugin's factory, as types.

A plugin registers a factory function for its arm, camera, tracker or tool and sets
members on it: ``PARAMS`` (the parameters the loader checks and documents) and, if it
has load-time checks beyond them, ``validate``. mypy types a ``def`` as a plain
callable, which has no attributes to set, so a plugin casts its function to one of
these protocols once, before setting them::

    hamming_factory = cast(CheckedFactory[HammingTracker], hamming_factory)
    hamming_factory.validate = _validate

A factory with members of its own (``simulated``, an arm's ``model``) extends one of
them with a Protocol of its own.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, TypeVar

from armtree.config.params import Param

from .rig import RigContext

ComponentT_co = TypeVar("ComponentT_co", covariant=True)


class ComponentFactory(Protocol[ComponentT_co]):
    """``factory(config, context)`` builds the component from its profile section
    (``config``, as parsed) and the rig's :class:`RigContext`; ``PARAMS`` are the
    section's parameters."""

    PARAMS: tuple[Param, ...]

    def __call__(self, config: dict[str, Any], context: RigContext) -> ComponentT_co: ...


class CheckedFactory(ComponentFactory[ComponentT_co], Protocol[ComponentT_co]):
    """A :class:`ComponentFactory` with load-time checks: ``validate(config, profile)``
    raises :class:`armtree.ConfigError` at the key to change (``armtree check`` runs it).
    The profile is the loader's :class:`armtree.Profile`, a layer above this one."""

    validate: Callable[[dict[str, Any], Any], None]
