"""Profile sections that plugins own: their name, JSON Schema and check.

armtree itself knows the sections every rig has (components, tags, places, table,
obstacles, workcell, calibration, ...). A plugin that needs a section of its own
(the built-in simulation's ``world:``) registers a :class:`ProfileSection` through
``armtree_profile_sections``; the profile loader then accepts the section, checks
its value against the schema's top-level ``type``, calls the section's ``check``,
lets ``--set`` change it, and ``armtree schema`` describes it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from armtree.errors import ConfigError
    from armtree.loader.profile import Profile

#: JSON Schema type -> the Python types a loaded YAML value of that type has.
_JSON_TYPES: dict[str, tuple[type, ...]] = {
    "object": (dict,),
    "array": (list,),
    "string": (str,),
    "number": (int, float),
    "integer": (int,),
    "boolean": (bool,),
}
#: How an error names each JSON Schema type.
_TYPE_WORDS = {
    "object": "a mapping",
    "array": "a list",
    "string": "a string",
    "number": "a number",
    "integer": "an integer",
    "boolean": "true or false",
}


@dataclass(frozen=True)
class ProfileSection:
    """A top-level profile section a plugin owns.

    ``schema`` is the JSON Schema (draft 7) of the section's value, as ``armtree
    schema`` shows it; its ``description`` is the section's one-line summary and its
    top-level ``type`` is checked when a profile loads. ``check(profile)`` returns
    the section's problems (:meth:`armtree.loader.profile.Profile.error` places each at its
    file, line and column); it is called for every profile, with or without the
    section, after armtree's own checks, unless the section already has the wrong
    type. It must not open ports or devices nor change the profile.
    """

    schema: dict[str, Any] = field(default_factory=dict)
    check: Callable[[Profile], list[ConfigError]] | None = None

    @property
    def summary(self) -> str:
        """The schema's description: what the section is for."""
        return str(self.schema.get("description", ""))

    def type_problem(self, value: Any) -> str | None:
        """``"expected a mapping"`` when ``value`` is not of the schema's top-level type."""
        wanted = self.schema.get("type")
        if value is None or wanted not in _JSON_TYPES:
            return None
        ok = isinstance(value, _JSON_TYPES[wanted])
        if wanted in ("number", "integer") and isinstance(value, bool):
            ok = False
        return None if ok else f"expected {_TYPE_WORDS[wanted]}"
