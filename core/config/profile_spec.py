"""The profile sections armtree declares with :mod:`armtree.config.spec`, by name.

Each entry is the section's declaration and, for a key with no default, who needs
it; the loader checks these sections with them, ``armtree schema`` describes them
and docs/profiles.md's key tables are generated from them.
"""

from __future__ import annotations

from .spec import Record
from .workcell import NEEDED_BY, WORKCELL

#: Section name -> (its declaration, who needs each key without a default).
SECTION_SPECS: dict[str, tuple[Record, dict[str, str]]] = {
    "workcell": (WORKCELL, NEEDED_BY),
}
