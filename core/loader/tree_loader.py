"""Loading tree files: validate everything, then build the py_trees behaviours.

Format (see docs/tree_files.md)::

    # yaml-language-server: $schema=tree.schema.json
    tree: load_ducky                 # name (default: the file's stem)
    description: ...
    rig: sim_dobot                   # default hardware profile; load_tree(rig=...) overrides
    tick_hz: 20                      # ticks per second (> 0)
    plugins: [my_skills, ./extra.py] # loaded before the nodes are checked
    params: {tag: {doc: marker role}, clean_up: {default: false}}
    blackboard: {clean_up: true}     # initial blackboard values
    root: NODE

A NODE is a mapping with exactly one key, its type:

* composite (``sequence``, ``selector``, ``parallel``): a list of children, or a
  mapping with ``children`` and options (``name``, ``memory``; a parallel's
  ``policy``: success_on_all | success_on_one | success_on_selected, with
  ``synchronise`` and ``selected``);
* decorator (``inverter``, ``retry``, ``timeout``, ...): a mapping with ``child``
  and its options;
* leaf: a mapping of its declared parameters (or nothing);
* ``subtree: {file: search.yaml, with: {tag: duckybot}, name: ..., namespace: ...}``:
  include another tree file's ``root``.

Every node takes an optional ``name`` (default: its type).

**Blackboard bindings.** A parameter value written ``"{key}"`` is bound to
blackboard key ``key`` (read for an input parameter, written for an output).
The blackboard is shared by the whole tree, included files too: what a subtree
writes (a found pose) is what its parent reads. The loader checks that every key
read is written by some output parameter, by a node that sets blackboard
variables, by a ``blackboard:`` section or by an override; otherwise it is an
error at the binding.

**Subtree parameters.** ``with: {tag: duckybot}`` substitutes the included
file's ``{tag}`` references at load time, before anything else: a value that is
exactly ``"{tag}"`` becomes the given value (any YAML type, or another binding
such as ``"{clean_up}"``, which remaps one key to another as BehaviorTree XML
ports do), and ``{tag}`` inside a longer string is replaced by its text, so
``"{{tag}_pose}"`` becomes the binding ``"{duckybot_pose}"``. References that are
not parameters stay blackboard bindings. A file's ``params:`` declares the
parameters it takes (``default`` makes one optional); ``with`` keys must then be
declared, and required ones given. For the top-level tree, ``--set NAME=VALUE``
gives a declared parameter. Include paths are relative to the including file,
then the working directory, then the shipped trees; cycles are errors.

**Namespaces.** By default the blackboard is shared. ``namespace: scan_a`` on a
subtree gives that instance its own keys, as py_trees' XML parser does for each
subtree: its bindings ``{key}`` (and its file's ``blackboard:`` keys) become
``scan_a/key``, while values given through ``with`` (``out: "{result}"``) and
absolute keys (``{/key}``) stay as they are. Namespaces nest. py_trees'
blackboard behaviours name their keys literally and are not namespaced.

**Errors.** Everything is checked before anything is built: unknown node types
and parameters (with did-you-mean), wrong types, missing required parameters,
nodes that are not one-key mappings, unbound blackboard keys, missing include
files and include cycles, bad ``plugins:``, and the hardware profile. All the
problems found are raised together as one :class:`armtree.ConfigError` whose
``errors`` each carry file, line and column.
"""

from __future__ import annotations

import gc
from collections import Counter
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from armtree.config.resolve import available, not_a_file, resolve
from armtree.config.yamlio import MarkedDict
from armtree.errors import ConfigError, Mark, did_you_mean, shown
from armtree.hooks.plugin_manager import PluginManager, Registry, get_plugin_manager

from .blackboard_use import BlackboardUse
from .load_context import LoadContext, LoadErrors, TreeFiles
from .node_builder import NodeBuilder
from .node_params import NodeParams
from .profile import Profile, override_sections, parse_overrides
from .subtree_include import SubtreeIncludes
from .tree import NodeInfo, Tree
from .tree_checks import RigChecks
from .tree_keys import TreeKeys
from .tree_params import TreeParams


def load_tree(
    path_or_name: str | Path,
    rig: str | Path | Profile | None = None,
    overrides: Iterable[str] = (),
    *,
    manager: PluginManager | None = None,
) -> Tree:
    """Find, validate and build a tree file.

    ``path_or_name``: a path, or a name looked up in the working directory, then
    among the shipped trees (``.yaml`` optional). ``rig``: a profile name, path or
    :class:`Profile` used instead of the tree's ``rig:``. ``overrides``:
    ``KEY=VALUE`` strings; a key whose first part is a profile section (arm,
    camera, tracker, planner, tags, places, obstacles, world, plugins) overrides
    the profile, ``tick_hz`` the tick rate, a declared tree parameter is given,
    any other key sets an initial blackboard value (dotted keys make nested
    mappings). ``manager``: the
    plugin manager to use (default: the process-wide one).

    Raises :class:`ConfigError` listing every problem found, each with its position.
    """
    path = resolve(path_or_name, "tree")
    if path is None:
        raise ConfigError(
            f"no tree {shown(str(path_or_name))} in the working directory or among the shipped "
            f"trees{not_a_file(path_or_name, 'tree')}"
            f"{did_you_mean(Path(str(path_or_name)).stem, available('tree'))}",
            file=str(path_or_name),
        )
    # A load allocates many small objects and frees none; pausing the cyclic garbage
    # collector meanwhile saves its repeated scans (about 15% of a 500-node load).
    collecting = gc.isenabled()
    gc.disable()
    try:
        return _Loader(manager or get_plugin_manager()).load(path, rig, list(overrides))
    finally:
        if collecting:
            gc.enable()


class _Loader:
    """One load: reads the top-level file, then hands each job to its collaborator.

    The top-level keys go to :class:`TreeKeys`, ``params:`` to :class:`TreeParams`,
    the nodes to :class:`NodeBuilder` (which opens subtrees through
    :class:`SubtreeIncludes`); the loader keeps the order of the steps, the plugin
    manager (which ``plugins:`` and the profile may replace) and the errors' order.
    """

    def __init__(self, manager: PluginManager) -> None:
        self.manager = manager
        self.errors = LoadErrors()
        self.files = TreeFiles(self.errors, read=self.read_other_format)
        self.nodes: dict[Any, NodeInfo] = {}
        #: The blackboard keys the tree reads and writes, and those --set gives.
        self.keys = BlackboardUse()
        self.blackboard: dict[str, Any] = {}
        #: The files' ``params:``: declared, bound per instance.
        self.params = TreeParams(self.errors.error)
        self.tree_keys = TreeKeys(self.errors, self.keys, self.blackboard)
        #: Made once the registry and the profile are known.
        self.builder: NodeBuilder | None = None

    def read_other_format(self, path: Path) -> Any:
        """A tree file a plugin reads (``armtree_read_tree``), or None to read it as YAML."""
        return self.manager.hook.armtree_read_tree(path=path)

    def fail(self) -> ConfigError:
        """One error listing all, ordered by file (as loaded), line and column."""
        return self.errors.fail(self.files.order())

    def load(self, path: Path, rig: str | Path | Profile | None, overrides: list[str]) -> Tree:
        data = self.files.parse(path)
        if data is None and not self.errors:
            self.errors.error(
                "the tree file is empty; it needs at least a root node", Mark(str(path), 1, 1)
            )
        if data is not None and not isinstance(data, MarkedDict):
            self.errors.error(
                "a tree file must be a mapping with a root node",
                getattr(data, "mark", None) or Mark(str(path), 1, 1),
            )
        if self.errors:
            raise self.fail()
        ctx = LoadContext(file=path, stack=(path,))
        self.tree_keys.check(data, ctx)
        parsed, bad = parse_overrides(overrides)
        self.errors.extend(bad)
        # plugins first: a plugin may own a profile section --set addresses
        self.manager = self.tree_keys.plugins(data, ctx, self.manager)
        sections = override_sections(self.manager)
        profile_overrides = [o for o in parsed if o.keys[0] in sections]
        for o in parsed:
            if o.keys == ("tick_hz",):
                data["tick_hz"] = o.value
                data.value_marks["tick_hz"] = o.mark
        other = [o for o in parsed if o.keys[0] not in sections and o.keys != ("tick_hz",)]
        profile = self.tree_keys.profile(data, ctx, rig, profile_overrides, self.manager)
        if profile is not None and profile.manager is not None:
            self.manager = profile.manager
        try:
            registry = self.manager.registry
        except ConfigError as exc:
            self.errors.extend(exc.errors)
            raise self.fail() from None
        self.builder = self.node_builder(registry, profile)
        declared = self.params.declared(data, ctx)
        given = {o.keys[0]: o for o in other if len(o.keys) == 1 and o.keys[0] in (declared or {})}
        ctx.params = self.params.bind(declared, {k: o.value for k, o in given.items()}, None, ctx)
        self.tree_keys.initial_blackboard(data, ctx)
        for o in other:
            if o.keys[0] not in given:
                _set_nested(self.blackboard, o.keys, o.value)
                self.keys.given(o.keys[0], o)
        tick_hz = self.tree_keys.tick_hz(data, ctx)
        root = None
        if "root" in data:
            root = self.builder.build(data["root"], data.value_mark("root"), ctx, "", Counter())
        else:
            self.errors.error("the tree has no root node", data.mark, ctx)
        expect = self.tree_keys.expectations(data, ctx, profile, self.manager)
        self.errors.extend(self.keys.unwritten_reads())
        self.errors.extend(self.keys.unread_set_keys(declared, sections))
        if self.errors:
            raise self.fail()
        assert root is not None
        name = data.get("tree") if isinstance(data.get("tree"), str) else path.stem
        return Tree(
            name=name,
            root=root,
            source=path,
            tick_hz=tick_hz,
            description=str(data.get("description") or ""),
            task=str(data.get("task") or ""),
            blackboard=self.blackboard,
            nodes=self.nodes,
            profile=profile,
            plugins=list(self.manager.specs),
            manager=self.manager,
            expect=expect,
        )

    def node_builder(self, registry: Registry, profile: Profile | None) -> NodeBuilder:
        """The builder of this load's nodes, its includes and parameter checks wired in."""
        rig_checks = RigChecks(profile) if profile is not None else None
        includes = SubtreeIncludes(
            files=self.files,
            errors=self.errors,
            params=self.params,
            tree_keys=self.tree_keys,
            load_plugins=self.load_included_plugins,
        )
        return NodeBuilder(
            registry=registry,
            errors=self.errors,
            params=NodeParams(self.errors, self.keys, rig_checks),
            includes=includes,
            nodes=self.nodes,
        )

    def load_included_plugins(self, data: MarkedDict, ctx: LoadContext) -> bool:
        """An included file's ``plugins:`` loaded and the builder's registry refreshed;
        False (its errors recorded) when the registry cannot be built."""
        assert self.builder is not None
        self.manager = self.tree_keys.plugins(data, ctx, self.manager)
        try:
            self.builder.registry = self.manager.registry
        except ConfigError as exc:
            self.errors.extend(exc.errors)
            return False
        return True


def _set_nested(target: dict[str, Any], keys: tuple[str, ...], value: Any) -> None:
    for key in keys[:-1]:
        child = target.get(key)
        if not isinstance(child, dict):
            child = {}
            target[key] = child
        target = child
    target[keys[-1]] = value
