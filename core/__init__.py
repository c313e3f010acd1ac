"""armtree: behaviour trees in YAML for low-cost, vision-guided robot arms.

The public names are those in ``__all__``; everything else is reached through the
layer that defines it (``armtree.loader.tree_loader``, ``armtree.api.rig``, ...; see
docs/architecture.md). Each public name lives in its layer and is looked up here on
first use (PEP 562) through :data:`_PUBLIC`, a table of exactly these names:
importing a submodule imports this package first, and the console scripts
(:mod:`armtree.cli.console`) must hold Ctrl-C before numpy, OpenCV and py_trees load,
so this module imports nothing. ``__init__.pyi`` states the same names for type
checkers; a test keeps the table, ``__all__`` and the stub equal.
"""

__version__ = "0.1.0"

#: Every public name -> the module that defines it.
_PUBLIC = {
    "ConfigError": "armtree.errors",
    "HardwareFault": "armtree.errors",
    "PlanningError": "armtree.errors",
    "Unreachable": "armtree.errors",
    "REQUIRED": "armtree.config.params",
    "Binding": "armtree.config.params",
    "Param": "armtree.config.params",
    "ParamKind": "armtree.config.params",
    "Place": "armtree.config.params",
    "Position": "armtree.config.params",
    "TagRole": "armtree.config.params",
    "Behaviour": "armtree.api.behaviour",
    "Skill": "armtree.api.skill.base",
    "ArmSkill": "armtree.api.skill.arm",
    "Action": "armtree.api.skill.actions",
    "SkillFailure": "armtree.api.skill.actions",
    "hookimpl": "armtree.hooks.hookspecs",
    "hookspec": "armtree.hooks.hookspecs",
    "Profile": "armtree.loader.profile",
    "load_profile": "armtree.loader.profile",
    "Tree": "armtree.loader.tree",
    "load_tree": "armtree.loader.tree_loader",
    "Run": "armtree.runtime.runner",
    "RunResult": "armtree.runtime.run_end",
    "run": "armtree.runtime.runner",
}

__all__ = [
    "REQUIRED",
    "Action",
    "ArmSkill",
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
    "Run",
    "RunResult",
    "Skill",
    "SkillFailure",
    "TagRole",
    "Tree",
    "Unreachable",
    "hookimpl",
    "hookspec",
    "load_profile",
    "load_tree",
    "run",
]


def __getattr__(name: str) -> object:
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib  # the first public name asked for pays for it

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_PUBLIC})
