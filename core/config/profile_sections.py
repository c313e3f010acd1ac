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
from typing import Any

from armtree.errors import ConfigError

from .spec import Record

#: Profile section -> component kind in the plugin registry.
COMPONENT_SECTIONS: dict[str, str] = {
    "arm": "arm",
    "camera": "camera",
    "tracker": "tracker",
    "planner": "planner",
}
#: Every top-level key armtree itself knows (plugins register more through
#: ``armtree_profile_sections``).
PROFILE_KEYS = (
    "profile",
    "description",
    *COMPONENT_SECTIONS,
    "tags",
    "places",
    "table",
    "obstacles",
    "workcell",
    "plugins",
    "watchdog",
    "include",
    "calibration",
)
#: Default limit of one tick, wall seconds (profiles set ``watchdog: {tick_s: ...}``).
DEFAULT_TICK_S = 120.0
#: Largest limit a profile may set, wall seconds.
MAX_TICK_S = 3600.0
#: Seconds of run time without progress that make a stall, unless the profile says.
DEFAULT_STALL_S = 60.0
#: Largest ``stall_s`` a profile may give, s (a day).
MAX_STALL_S = 86_400.0

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
    type. It must not open ports or devices nor change the profile. ``spec``, when the
    section is declared with :mod:`armtree.config.spec`, is that declaration: docs/profiles.md's
    key tables of the section are generated from it.
    """

    schema: dict[str, Any] = field(default_factory=dict)
    #: Called with the loaded :class:`~armtree.loader.profile.Profile`.
    check: Callable[[Any], list[ConfigError]] | None = None
    spec: Record | None = None

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
