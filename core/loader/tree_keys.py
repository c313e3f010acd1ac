"""A tree file's top-level keys: each checked (``tree:``, ``description:``, ``task:``, ``rig:``,
``tick_hz:``, ``plugins:``, ``blackboard:``, ``expect:``, unknown keys with
did-you-mean) and read into what the load needs: the plugins to load, the profile,
the tick rate, the initial blackboard and the expectations. ``params:`` is
:mod:`armtree.loader.tree_params`' job, ``root:`` :mod:`armtree.loader.node_builder`'s."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from armtree.api.outcomes.expect import parse_expectations, predicates_for
from armtree.api.outcomes.truth import WorldTruth
from armtree.config.params import Param, check_value
from armtree.config.yamlio import MarkedDict, MarkedList, plain
from armtree.errors import ConfigError, Mark, shown
from armtree.hooks.plugin_manager import PluginManager

from .blackboard_use import BlackboardUse
from .load_context import LoadContext, LoadErrors
from .profile import Override, Profile, load_profile
from .tree_params import BINDING, substitute

#: Every top-level key a tree file may have.
TREE_KEYS = (
    "tree",
    "description",
    "task",
    "rig",
    "tick_hz",
    "plugins",
    "params",
    "blackboard",
    "expect",
    "root",
)
DEFAULT_TICK_HZ = 20.0
#: Tick rates a tree may ask for, Hz: slower would leave a tick for minutes, faster
#: than any arm's status stream is work without information.
TICK_HZ_RANGE = (0.1, 1000.0)


class TreeKeys:
    """Checks and reads the top-level keys of the tree files of one load.

    Problems go to ``errors``; the initial blackboard values of every file go
    into ``blackboard`` (the first file to give a key wins) and are noted as
    written in ``keys``.
    """

    def __init__(self, errors: LoadErrors, keys: BlackboardUse, blackboard: dict[str, Any]):
        self._errors = errors
        self._keys = keys
        self.blackboard = blackboard

    def check(self, data: MarkedDict, ctx: LoadContext) -> None:
        """Unknown keys (with did-you-mean) and the types of the plain ones."""
        error = self._errors.error
        self._errors.unknown_keys(data, TREE_KEYS, "unknown tree key", ctx)
        for key in ("tree", "description", "task", "rig"):
            if data.get(key) is not None and not isinstance(data[key], str):
                error(
                    f"{key}: expected a string, got {shown(data[key])}", data.value_mark(key), ctx
                )
        if data.get("blackboard") is not None and not isinstance(data["blackboard"], dict):
            error(
                "blackboard: expected a mapping of key: value", data.value_mark("blackboard"), ctx
            )

    def plugins(self, data: MarkedDict, ctx: LoadContext, manager: PluginManager) -> PluginManager:
        """``manager`` extended with the file's ``plugins:`` (``.py`` paths relative to the
        file); ``manager`` itself when it names none or they do not load."""
        specs = data.get("plugins")
        if specs is None:
            return manager
        if not isinstance(specs, MarkedList) or not all(isinstance(s, str) for s in specs):
            self._errors.error(
                "plugins: expected a list of module names or .py files",
                data.value_mark("plugins"),
                ctx,
            )
            return manager
        where: dict[str, Mark] = {}
        resolved = []
        for i, spec in enumerate(specs):
            if spec.endswith(".py") and not Path(spec).is_absolute():
                spec = str((ctx.file.parent / spec).resolve())
            resolved.append(spec)
            mark = specs.item_mark(i)
            if mark is not None:
                where[spec] = mark
        try:
            return manager.extended(resolved, where)
        except ConfigError as exc:
            self._errors.extend(exc.errors, first=True)
            return manager

    def profile(
        self,
        data: MarkedDict,
        ctx: LoadContext,
        rig: str | Path | Profile | None,
        overrides: list[Override],
        manager: PluginManager,
    ) -> Profile | None:
        """The profile ``rig`` names (a name, path or :class:`Profile`), else the file's
        ``rig:``, with ``overrides`` applied; None without one or when it is invalid."""
        try:
            if isinstance(rig, Profile):
                return rig.with_overrides(overrides, manager) if overrides else rig
            if rig is not None:
                return load_profile(
                    rig, overrides, manager=manager, where=Mark(f"--rig {rig}", 1, 1)
                )
            if isinstance(data.get("rig"), str):
                return load_profile(
                    data["rig"],
                    overrides,
                    manager=manager,
                    base=ctx.file.parent,
                    where=data.value_mark("rig"),
                )
        except ConfigError as exc:
            self._errors.extend(exc.errors)
            return None
        for o in overrides:
            self._errors.error(
                f"{'.'.join(o.keys)} sets a profile value but the tree names no rig; "
                "give one with --rig PROFILE",
                o.mark,
            )
        return None

    def expectations(
        self,
        data: MarkedDict,
        ctx: LoadContext,
        profile: Profile | None,
        manager: PluginManager,
    ) -> list:
        """The top-level file's ``expect:`` (an included file's is not its includer's),
        its ``{param}`` references substituted and its names checked against the
        profile's world."""
        if data.get("expect") is None:
            return []
        try:
            predicates = predicates_for(manager.registry)
        except ConfigError as exc:
            self._errors.extend(exc.errors)
            return []
        world = world_inventory(profile, manager) if profile is not None else None
        expect, errors = parse_expectations(
            substitute(data["expect"], ctx.params),
            data.value_mark("expect"),
            str(ctx.file),
            world,
            predicates,
        )
        self._errors.extend(errors)
        return expect

    def tick_hz(self, data: MarkedDict, ctx: LoadContext) -> float:
        """The file's ``tick_hz:`` in Hz (:data:`DEFAULT_TICK_HZ` when absent or invalid)."""
        value = data.get("tick_hz", DEFAULT_TICK_HZ)
        try:
            hz = check_value(Param("tick_hz", "float"), value)
        except ValueError as exc:
            self._errors.error(f"tick_hz: {exc}", data.value_mark("tick_hz"), ctx)
            return DEFAULT_TICK_HZ
        low, high = TICK_HZ_RANGE
        if not low <= hz <= high:
            self._errors.error(
                f"tick_hz: expected a rate from {low:g} to {high:g} Hz, got {shown(value)}",
                data.value_mark("tick_hz"),
                ctx,
            )
            return DEFAULT_TICK_HZ
        return hz

    def initial_blackboard(self, data: MarkedDict, ctx: LoadContext) -> None:
        """The file's ``blackboard:`` values, in its namespace, its parameters filled in."""
        values = data.get("blackboard")
        if not isinstance(values, MarkedDict):
            return
        for key, value in values.items():
            if not isinstance(key, str) or not BINDING.match("{" + key + "}"):
                self._errors.error(
                    f"blackboard: {shown(key)} is not a valid key (letters, digits, _ . /)",
                    values.key_mark(key),
                    ctx,
                )
                continue
            if ctx.namespace and not key.startswith("/"):
                key = f"{ctx.namespace}/{key}"
            self.blackboard.setdefault(key, plain(substitute(value, ctx.params)))
            self._keys.write(key)


def world_inventory(profile: Profile, manager: PluginManager) -> WorldTruth:
    """The profile's nominal world from ``armtree_world_inventory``; without a plugin
    that models it, the names of its tag roles and places (kinds unknown)."""
    world = manager.hook.armtree_world_inventory(profile=profile)
    if world is not None:
        return world
    return WorldTruth(
        roles={role: [] for role in profile.tags()},
        places={name: (xyz[0], xyz[1], xyz[2]) for name, xyz in profile.places().items()},
        complete=False,
    )
