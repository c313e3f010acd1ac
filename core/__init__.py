"""armtree: behaviour trees in YAML for low-cost, vision-guided robot arms.

Public names (outside tests rely on them): :data:`hookimpl`, :data:`hookspec`,
:class:`ConfigError`, :func:`load_tree`, :func:`load_profile`, :func:`run`; for
plugins :class:`Behaviour`, :class:`Param`, and :data:`TagRole`, :data:`Place` and
:data:`Position` for ``typing.Annotated`` parameters of plain py_trees behaviours.

They are imported on first use (PEP 562): ``import armtree`` itself is cheap, so
the command line can take over Ctrl-C before numpy, OpenCV and py_trees load.
"""

from __future__ import annotations

import importlib

# Not typing's: importing typing costs time before the command line holds Ctrl-C.
TYPE_CHECKING = False
if TYPE_CHECKING:
    from typing import Any

    from armtree.api.behaviour import Behaviour
    from armtree.config.params import REQUIRED, Binding, Param, ParamKind, Place, Position, TagRole
    from armtree.hooks.hookspecs import hookimpl, hookspec
    from armtree.loader.profile import Profile, load_profile
    from armtree.loader.tree import Tree
    from armtree.loader.tree_loader import load_tree
    from armtree.runtime.run_end import RunResult
    from armtree.runtime.runner import Run, run

    from .errors import ConfigError, HardwareFault, PlanningError, Unreachable

__version__ = "0.1.0"

#: Public name -> the submodule that defines it.
_LAZY = {
    "ConfigError": "errors",
    "HardwareFault": "errors",
    "PlanningError": "errors",
    "Unreachable": "errors",
    "Behaviour": "api.behaviour",
    "hookimpl": "hooks.hookspecs",
    "hookspec": "hooks.hookspecs",
    "REQUIRED": "config.params",
    "Binding": "config.params",
    "Param": "config.params",
    "ParamKind": "config.params",
    "Place": "config.params",
    "Position": "config.params",
    "TagRole": "config.params",
    "Profile": "loader.profile",
    "load_profile": "loader.profile",
    "Run": "runtime.runner",
    "RunResult": "runtime.runner",
    "run": "runtime.runner",
    "Tree": "loader.tree",
    "load_tree": "loader.tree_loader",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        # ``armtree.runtime.runner`` and friends without an explicit import, as before.
        try:
            return importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})


__all__ = [
    "REQUIRED",
    "Behaviour",
    "Binding",
    "ConfigError",
    "HardwareFault",
    "Param",
    "ParamKind",
    "Place",
    "PlanningError",
    "Position",
    "Profile",
    "Tree",
    "Run",
    "RunResult",
    "TagRole",
    "Unreachable",
    "hookimpl",
    "hookspec",
    "load_profile",
    "load_tree",
    "run",
]
