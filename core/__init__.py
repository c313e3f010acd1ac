"""armtree: behaviour trees in YAML for low-cost, vision-guided robot arms.

Public names (outside tests rely on them): :data:`hookimpl`, :data:`hookspec`,
:class:`ConfigError`, :func:`load_tree`, :func:`load_profile`, :func:`run`.
"""

from __future__ import annotations

from .behaviour import Behaviour
from .errors import ConfigError, HardwareFault, PlanningError, Unreachable
from .hookspecs import hookimpl, hookspec
from .params import REQUIRED, Binding, Param
from .runtime import Run, RunResult, run

__version__ = "0.1.0"

__all__ = [
    "REQUIRED",
    "Behaviour",
    "Binding",
    "ConfigError",
    "HardwareFault",
    "Param",
    "PlanningError",
    "Run",
    "RunResult",
    "Unreachable",
    "hookimpl",
    "hookspec",
    "run",
]
