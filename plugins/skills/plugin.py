"""Registration of the built-in skills: the behaviours trees are made of."""

from __future__ import annotations

from typing import Any

import armtree

from .conditions import ArmIdle, AtPlace, Holding, Misplaced, TagNear, TagVisible
from .motion import Home, MoveTo
from .pick import Grasp, Pick
from .place import Place, Release
from .search import CleanUp, Search
from .servo import VisualServo
from .steps import Approach, LookFor, SearchStep, Sweep
from .track import Track


@armtree.hookimpl
def armtree_behaviours() -> dict[str, Any]:
    """Conditions (tag_visible, tag_near, misplaced, holding, at_place, arm_idle), fine-grained actions
    (look, approach, grasp, release, sweep, search_step, move_to, home, track,
    visual_servo) and the composites built from them (search, clean_up, pick, place)."""
    return {
        "tag_visible": TagVisible,
        "tag_near": TagNear,
        "misplaced": Misplaced,
        "holding": Holding,
        "at_place": AtPlace,
        "arm_idle": ArmIdle,
        "look": LookFor,
        "approach": Approach,
        "grasp": Grasp,
        "release": Release,
        "sweep": Sweep,
        "search_step": SearchStep,
        "move_to": MoveTo,
        "home": Home,
        "track": Track,
        "visual_servo": VisualServo,
        "search": Search,
        "clean_up": CleanUp,
        "pick": Pick,
        "place": Place,
    }
