"""armtree: behaviour trees in YAML for low-cost, vision-guided robot arms.

Public names (outside tests rely on them): :data:`hookimpl`, :data:`hookspec`,
:class:`ConfigError`, :func:`load_tree`, :func:`load_profile`, :func:`run`.
"""

from __future__ import annotations

from .behaviour import Behaviour
from .errors import ConfigError, HardwareFault, PlanningError, Unreachable
from .hookspecs import hookimpl, hookspec
from .params import REQUIRED, Binding, Param
from .profile import Profile, load_profile
from .runtime import Run, RunResult, run
from .tree import Tree
from .tree_loader import load_tree

__version__ = "0.1.0"

__all__ = [
    "REQUIRED",
    "Behaviour",
    "Binding",
    "ConfigError",
    "HardwareFault",
    "Param",
    "PlanningError",
    "Profile",
    "Tree",
    "Run",
    "RunResult",
    "Unreachable",
    "hookimpl",
    "hookspec",
    "load_profile",
    "load_tree",
    "run",
]
