"""Registration of the built-in skills: the behaviours trees are made of."""

from __future__ import annotations

from typing import Any

import armtree

from .manipulation import Pick, Place
from .motion import Home, MoveTo
from .search import CleanUp, Search
from .servo import VisualServo
from .track import Track


@armtree.hookimpl
def armtree_behaviours() -> dict[str, Any]:
    """search, track, clean_up, pick, place, visual_servo, move_to and home."""
    return {
        "move_to": MoveTo,
        "home": Home,
        "search": Search,
        "clean_up": CleanUp,
        "track": Track,
        "pick": Pick,
        "place": Place,
        "visual_servo": VisualServo,
    }
