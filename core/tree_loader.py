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
import re
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import py_trees

from .behaviour import Behaviour
from .blackboard_use import BlackboardUse
from .builtin_behaviours import COMPOSITE, DECORATOR, LEAF
from .constructor_params import declared_params, name_argument, takes_signature_params
from .errors import ConfigError, Mark, shown
from .outcomes import WorldTruth, parse_expectations, predicates_for
from .params import Binding, Param, check_value
from .plugin_manager import PluginManager, did_you_mean, get_plugin_manager
from .profile import Override, Profile, load_profile, override_sections, parse_overrides
from .resolve import available, resolve
from .tree import NodeInfo, Tree
from .tree_checks import RigChecks
from .tree_params import (
    BINDING,
    TreeParams,
    has_missing,
    placeholders,
    substitute,
)
from .yamlio import MarkedDict, MarkedList, error_at, load_yaml_file

#: Every top-level key a tree file may have.
TREE_KEYS = (
    "tree",
    "description",
    "rig",
    "tick_hz",
    "plugins",
    "params",
    "blackboard",
    "expect",
    "root",
)
#: Keys of a ``subtree`` node.
SUBTREE_KEYS = ("file", "with", "name", "namespace")
DEFAULT_TICK_HZ = 20.0
#: Tick rates a tree may ask for, Hz: slower would leave a tick for minutes, faster
#: than any arm's status stream is work without information.
TICK_HZ_RANGE = (0.1, 1000.0)
#: Most nodes one tree may build, its subtrees included (ten subtrees of ten subtrees
#: of ... would otherwise multiply without bound).
MAX_NODES = 20_000
#: Deepest chain of subtree includes.
MAX_INCLUDE_DEPTH = 32


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
            f"trees{did_you_mean(Path(str(path_or_name)).stem, available('tree'))}",
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


@dataclass
class _Context:
    """Where the loader is: the file, its parameters and the include chain."""

    file: Path
    params: dict[str, Any] = field(default_factory=dict)
    stack: tuple[Path, ...] = ()
    included_from: Mark | None = None
    #: Blackboard namespace of this subtree instance ("" for the shared one).
    namespace: str = ""


@dataclass
class _Node:
    """What is known about one node while checking it."""

    type: str
    mark: Mark | None
    name: str
    path: str


class _Loader:
    """One load: collects errors, node info and (in :attr:`keys`) blackboard reads and writes."""

    def __init__(self, manager: PluginManager) -> None:
        self.manager = manager
        self.registry: Any = None
        self.errors: list[ConfigError] = []
        self.files: dict[Path, Any] = {}
        self.nodes: dict[Any, NodeInfo] = {}
        #: The blackboard keys the tree reads and writes, and those --set gives.
        self.keys = BlackboardUse()
        self.blackboard: dict[str, Any] = {}
        self.node_count = 0
        #: The files' ``params:``: declared, bound per instance.
        self.params = TreeParams(self.error)
        #: Resolves places, tag roles, reach and rig parts once the profile is known.
        self.rig_checks: RigChecks | None = None

    # ------------------------------------------------------------------ errors

    def error(self, message: str, mark: Mark | None, ctx: _Context | None = None) -> None:
        if ctx is not None and ctx.included_from is not None:
            message = f"{message} (included from {ctx.included_from})"
        self.errors.append(error_at(message, mark, str(ctx.file) if ctx else None))

    def fail(self) -> ConfigError:
        """One error listing all, ordered by file (as loaded), line and column."""
        order = {str(path): i for i, path in enumerate(self.files)}
        errors = sorted(
            self.errors,
            key=lambda e: (order.get(e.file or "", len(order)), e.line or 0, e.column or 0),
        )
        # A subtree included twice reports the same problem at the same place once.
        errors = list({(e.file, e.line, e.column, e.message): e for e in errors}.values())
        first = errors[0]
        return ConfigError(first.message, first.file, first.line, first.column, errors)

    # ------------------------------------------------------------------ files

    def parse(self, path: Path) -> Any:
        """Parse a file once per load; a file that fails to parse records its error once."""
        if path not in self.files:
            try:
                self.files[path] = load_yaml_file(path)
            except ConfigError as exc:
                self.errors.extend(exc.errors)
                self.files[path] = None
        return self.files[path]

    def load(self, path: Path, rig: Any, overrides: list[str]) -> Tree:
        data = self.parse(path)
        if data is None and not self.errors:
            self.error(
                "the tree file is empty; it needs at least a root node", Mark(str(path), 1, 1)
            )
        if data is not None and not isinstance(data, MarkedDict):
            self.error(
                "a tree file must be a mapping with a root node",
                getattr(data, "mark", None) or Mark(str(path), 1, 1),
            )
        if self.errors:
            raise self.fail()
        ctx = _Context(file=path, stack=(path,))
        self.check_keys(data, ctx)
        parsed, bad = parse_overrides(overrides)
        self.errors.extend(bad)
        self.load_plugins(data, ctx)  # first: a plugin may own a profile section --set addresses
        sections = override_sections(self.manager)
        profile_overrides = [o for o in parsed if o.keys[0] in sections]
        for o in parsed:
            if o.keys == ("tick_hz",):
                data["tick_hz"] = o.value
                data.value_marks["tick_hz"] = o.mark
        other = [o for o in parsed if o.keys[0] not in sections and o.keys != ("tick_hz",)]
        profile = self.load_profile(data, ctx, rig, profile_overrides)
        if profile is not None:
            self.rig_checks = RigChecks(profile)
        try:
            self.registry = self.manager.registry
        except ConfigError as exc:
            self.errors.extend(exc.errors)
            raise self.fail() from None
        declared = self.params.declared(data, ctx)
        given = {o.keys[0]: o for o in other if len(o.keys) == 1 and o.keys[0] in (declared or {})}
        ctx.params = self.params.bind(declared, {k: o.value for k, o in given.items()}, None, ctx)
        self.initial_blackboard(data, ctx)
        for o in other:
            if o.keys[0] not in given:
                _set_nested(self.blackboard, o.keys, o.value)
                self.keys.given(o.keys[0], o)
        tick_hz = self.tick_hz(data, ctx)
        root = None
        if "root" in data:
            root = self.build(data["root"], data.value_mark("root"), ctx, "", Counter())
        else:
            self.error("the tree has no root node", data.mark, ctx)
        expect = self.expectations(data, ctx, profile)
        self.errors += self.keys.unwritten_reads()
        self.errors += self.keys.unread_set_keys(declared, sections)
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
            blackboard=self.blackboard,
            nodes=self.nodes,
            profile=profile,
            plugins=list(self.manager.specs),
            manager=self.manager,
            expect=expect,
        )

    def check_keys(self, data: MarkedDict, ctx: _Context) -> None:
        for key in data:
            if key not in TREE_KEYS:
                self.error(
                    f"unknown tree key {shown(key)}{did_you_mean(str(key), TREE_KEYS)}",
                    data.key_mark(key),
                    ctx,
                )
        for key in ("tree", "description", "rig"):
            if data.get(key) is not None and not isinstance(data[key], str):
                self.error(
                    f"{key}: expected a string, got {shown(data[key])}", data.value_mark(key), ctx
                )
        if data.get("blackboard") is not None and not isinstance(data["blackboard"], dict):
            self.error(
                "blackboard: expected a mapping of key: value", data.value_mark("blackboard"), ctx
            )

    def load_plugins(self, data: MarkedDict, ctx: _Context) -> None:
        specs = data.get("plugins")
        if specs is None:
            return
        if not isinstance(specs, MarkedList) or not all(isinstance(s, str) for s in specs):
            self.error(
                "plugins: expected a list of module names or .py files",
                data.value_mark("plugins"),
                ctx,
            )
            return
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
            self.manager = self.manager.extended(resolved, where)
        except ConfigError as exc:
            self.errors.extend(exc.errors)

    def load_profile(
        self, data: MarkedDict, ctx: _Context, rig: Any, overrides: list[Override]
    ) -> Profile | None:
        try:
            if isinstance(rig, Profile):
                profile = rig.with_overrides(overrides, self.manager) if overrides else rig
            elif rig is not None:
                profile = load_profile(
                    rig, overrides, manager=self.manager, where=Mark(f"--rig {rig}", 1, 1)
                )
            elif isinstance(data.get("rig"), str):
                profile = load_profile(
                    data["rig"],
                    overrides,
                    manager=self.manager,
                    base=ctx.file.parent,
                    where=data.value_mark("rig"),
                )
            else:
                for o in overrides:
                    self.error(
                        f"{'.'.join(o.keys)} sets a profile value but the tree names no rig; "
                        "give one with --rig PROFILE",
                        o.mark,
                    )
                return None
        except ConfigError as exc:
            self.errors.extend(exc.errors)
            return None
        if profile.manager is not None:
            self.manager = profile.manager
        return profile

    def expectations(self, data: MarkedDict, ctx: _Context, profile: Profile | None) -> list:
        """The top-level file's ``expect:`` (an included file's is not its includer's),
        its ``{param}`` references substituted and its names checked against the
        profile's world."""
        if data.get("expect") is None:
            return []
        try:
            predicates = predicates_for(self.manager)
        except ConfigError as exc:
            self.errors.extend(exc.errors)
            return []
        world = world_inventory(profile, self.manager) if profile is not None else None
        expect, errors = parse_expectations(
            substitute(data["expect"], ctx.params),
            data.value_mark("expect"),
            str(ctx.file),
            world,
            predicates,
        )
        self.errors.extend(errors)
        return expect

    def tick_hz(self, data: MarkedDict, ctx: _Context) -> float:
        value = data.get("tick_hz", DEFAULT_TICK_HZ)
        try:
            hz = check_value(Param("tick_hz", "float"), value)
        except ValueError as exc:
            self.error(f"tick_hz: {exc}", data.value_mark("tick_hz"), ctx)
            return DEFAULT_TICK_HZ
        low, high = TICK_HZ_RANGE
        if not low <= hz <= high:
            self.error(
                f"tick_hz: expected a rate from {low:g} to {high:g} Hz, got {shown(value)}",
                data.value_mark("tick_hz"),
                ctx,
            )
            return DEFAULT_TICK_HZ
        return hz

    def initial_blackboard(self, data: MarkedDict, ctx: _Context) -> None:
        values = data.get("blackboard")
        if not isinstance(values, MarkedDict):
            return
        for key, value in values.items():
            if not isinstance(key, str) or not BINDING.match("{" + key + "}"):
                self.error(
                    f"blackboard: {shown(key)} is not a valid key (letters, digits, _ . /)",
                    values.key_mark(key),
                    ctx,
                )
                continue
            if ctx.namespace and not key.startswith("/"):
                key = f"{ctx.namespace}/{key}"
            self.blackboard.setdefault(key, _plain(substitute(value, ctx.params)))
            self.keys.write(key)

    # ------------------------------------------------------------ parameters

    # ------------------------------------------------------------------ nodes

    def build(
        self,
        value: Any,
        mark: Mark | None,
        ctx: _Context,
        parent: str,
        siblings: Counter,
        name: str | None = None,
    ) -> py_trees.behaviour.Behaviour | None:
        """Check one node and, when it and its children are valid, build it."""
        self.node_count += 1
        if self.node_count > MAX_NODES:
            if self.node_count == MAX_NODES + 1:
                self.error(
                    f"the tree has more than {MAX_NODES:,} nodes with its subtrees included; "
                    "is a subtree included inside itself many times over?",
                    getattr(value, "mark", None) or mark,
                    ctx,
                )
            return None
        if not isinstance(value, MarkedDict) or len(value) != 1:
            got = list(value) if isinstance(value, dict) else value
            self.error(
                "a node is a mapping with exactly one key, its type (e.g. `success: {}` or "
                f"`sequence: [...]`); got {shown(got)}",
                getattr(value, "mark", None) or mark,
                ctx,
            )
            return None
        ntype = next(iter(value))
        spec = value[ntype]
        type_mark = value.key_mark(ntype)
        spec_mark = value.value_mark(ntype)
        if ntype == "subtree":
            return self.include(spec, type_mark, spec_mark, ctx, parent, siblings, name)
        if not isinstance(ntype, str) or not self.registry.has("behaviour", ntype):
            options = self.registry.names("behaviour") + ["subtree"]
            self.error(
                f"unknown node type {shown(ntype)}{did_you_mean(str(ntype), options)}",
                type_mark,
                ctx,
            )
            self.check_orphans(spec, spec_mark, ctx, parent)
            return None
        factory = self.registry.get("behaviour", ntype).factory
        kind = node_kind(factory)
        children_spec: Any = None
        children_mark = spec_mark
        if kind == COMPOSITE and isinstance(spec, MarkedList):
            options: MarkedDict = MarkedDict(mark=spec_mark)
            children_spec = spec
        elif spec is None and kind == LEAF:
            options = MarkedDict(mark=spec_mark)
        elif isinstance(spec, MarkedDict):
            options = MarkedDict(spec, mark=spec.mark)
            options.key_marks, options.value_marks = spec.key_marks, spec.value_marks
            if kind == COMPOSITE:
                if "children" not in spec:
                    self.error(f"{ntype} needs children: a list of nodes", spec_mark, ctx)
                children_spec = options.pop("children", MarkedList(mark=spec_mark))
                children_mark = spec.value_mark("children")
            elif kind == DECORATOR:
                if "child" not in spec:
                    self.error(f"{ntype} needs a child node (child: {{...}})", spec_mark, ctx)
                elif spec["child"] is None:
                    self.error(
                        f"{ntype}: child is empty; give it a node (child: {{...}})",
                        spec.value_mark("child") or spec.key_mark("child"),
                        ctx,
                    )
                children_spec = options.pop("child", None)
                children_mark = spec.value_mark("child")
        else:
            what = {
                COMPOSITE: "a list of children or a mapping with children",
                DECORATOR: "a mapping with child and its options",
                LEAF: "a mapping of its parameters",
            }[kind]
            self.error(f"{ntype} takes {what}; got {shown(spec)}", spec_mark, ctx)
            return None
        node_name = name or self.node_name(options, ntype, ctx)
        options.pop("name", None)
        siblings[node_name] += 1
        path = f"{parent}/{node_name}" if parent else node_name
        if siblings[node_name] > 1:
            path += f"#{siblings[node_name]}"
        node = _Node(ntype, type_mark, node_name, path)
        params = self.check_params(factory, options, node, ctx)
        if self.rig_checks is not None:
            # a behaviour whose workcell needs depend on its parameters says so through
            # workcell_for(params) (a sweep needs the survey region only with sweep: true)
            workcell_for = getattr(factory, "workcell_for", None)
            workcell = (
                workcell_for(params or {})
                if callable(workcell_for)
                else getattr(factory, "WORKCELL", ())
            )
            for error in self.rig_checks.needs(
                ntype,
                getattr(factory, "NEEDS", ()),
                getattr(factory, "RESOURCES", ()),
                type_mark,
                workcell,
            ):
                self.error(error.message, type_mark, ctx)
        built_children: Any = None
        if kind == COMPOSITE:
            built_children = self.build_children(children_spec, children_mark, ctx, path)
        elif kind == DECORATOR and children_spec is not None:
            built_children = self.build(children_spec, children_mark, ctx, path, Counter())
        if params is None or (kind != LEAF and built_children is None):
            return None
        if kind == COMPOSITE:
            params["children"] = built_children
        elif kind == DECORATOR:
            params["child"] = built_children
        try:
            behaviour = construct(factory, node_name, params)
        except Exception as exc:  # noqa: BLE001 - a plugin's constructor error is shown at the node
            self.error(f"{ntype} {shown(node_name)}: {exc}", type_mark, ctx)
            return None
        given = {k: v for k, v in params.items() if k not in ("children", "child")}
        self.nodes[behaviour.id] = NodeInfo(path, ntype, type_mark, given)
        self.adopt(behaviour, path, ntype, type_mark)
        return behaviour

    def adopt(self, behaviour: Any, path: str, ntype: str, mark: Mark | None) -> None:
        """Give node info to behaviours a factory made inside itself (idioms, skill subtrees)."""
        for child in behaviour.children:
            if child.id not in self.nodes:
                child_path = f"{path}/{child.name}"
                self.nodes[child.id] = NodeInfo(child_path, ntype, mark)
                self.adopt(child, child_path, ntype, mark)

    def node_name(self, options: MarkedDict, ntype: str, ctx: _Context) -> str:
        if "name" not in options:
            return ntype
        raw = options.pop("name")
        value = substitute(raw, ctx.params)
        if has_missing(value):
            return ntype
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            value = str(value)
        if not isinstance(value, str) or not value:
            self.error(
                f"name: expected a non-empty string, got {shown(raw)}",
                options.value_mark("name"),
                ctx,
            )
            return ntype
        if "/" in value:
            self.error(
                f"name: {shown(value)} may not contain '/' (it separates paths)",
                options.value_mark("name"),
                ctx,
            )
        return value

    def build_children(self, spec: Any, mark: Mark | None, ctx: _Context, path: str) -> list | None:
        if not isinstance(spec, MarkedList):
            self.error(f"children: expected a list of nodes, got {shown(spec)}", mark, ctx)
            return None
        siblings: Counter = Counter()
        built = [
            self.build(child, spec.item_mark(i), ctx, path, siblings)
            for i, child in enumerate(spec)
        ]
        return None if any(b is None for b in built) else built

    def check_orphans(self, spec: Any, mark: Mark | None, ctx: _Context, parent: str) -> None:
        """Check the children of a node of unknown type, so their errors are reported too."""
        if isinstance(spec, MarkedList):
            self.build_children(spec, mark, ctx, parent)
        elif isinstance(spec, MarkedDict):
            if isinstance(spec.get("children"), MarkedList):
                self.build_children(spec["children"], spec.value_mark("children"), ctx, parent)
            if isinstance(spec.get("child"), MarkedDict):
                self.build(spec["child"], spec.value_mark("child"), ctx, parent, Counter())

    def check_params(
        self, factory: Any, options: MarkedDict, node: _Node, ctx: _Context
    ) -> dict[str, Any] | None:
        """Validated parameters with defaults filled in, or None after recording errors."""
        declared = {p.name: p for p in declared_params(factory)}
        bindable = is_bindable(factory)
        writes = set(getattr(factory, "writes", ()))
        reads = set(getattr(factory, "reads", ()))
        before = len(self.errors)
        incomplete = False
        params: dict[str, Any] = {}
        for key, raw in options.items():
            mark = options.value_mark(key)
            param = declared.get(key)
            if param is None:
                hint = did_you_mean(str(key), [*declared, "name"])
                if not hint and not declared:
                    hint = f"; {node.type} takes no parameters"
                self.error(
                    f"{node.type} has no parameter {shown(key)}{hint}", options.key_mark(key), ctx
                )
                continue
            value = substitute(raw, ctx.params, ctx.namespace)
            if has_missing(value):
                incomplete = True
                continue
            binding = BINDING.match(value) if isinstance(value, str) else None
            if binding and (bindable or param.type != "str"):
                if not bindable:
                    self.error(
                        f"{node.type}.{key} cannot be bound to the blackboard; give a value",
                        mark,
                        ctx,
                    )
                    continue
                key_name = binding.group(1)
                params[key] = Binding(key_name)
                if param.io in ("out", "inout"):
                    self.keys.write(key_name)
                if param.io in ("in", "inout"):
                    self.keys.read(key_name, mark, ctx.included_from)
                continue
            if param.io == "out":
                self.error(
                    f'{node.type}.{key} is an output: give the blackboard key to write as "{{key}}"',
                    mark,
                    ctx,
                )
                continue
            if value is None and not param.required and param.default is None:
                params[key] = None
                continue
            try:
                params[key] = check_value(param, _plain(value))
            except ValueError as exc:
                self.error(f"{node.type}.{key}: {exc}", mark, ctx)
                continue
            if key in writes and isinstance(value, str):
                self.keys.write(value)
            self.check_on_rig(f"{node.type}.{key}", param, params[key], mark, ctx)
            if key in reads:
                self.keys.read_named(value)
        for pname, param in declared.items():
            if pname in params or pname in options:
                continue
            if param.required:
                doc = f" ({param.doc})" if param.doc else ""
                self.error(f"{node.type} needs parameter {pname!r}{doc}", node.mark, ctx)
            else:
                params[pname] = param.default
                self.check_on_rig(
                    f"{node.type}.{pname} (its default)", param, param.default, node.mark, ctx
                )
        return params if len(self.errors) == before and not incomplete else None

    def check_on_rig(
        self, where: str, param: Param, value: Any, mark: Mark | None, ctx: _Context
    ) -> None:
        """A value resolved against the profile (see :mod:`armtree.tree_checks`)."""
        checks = self.rig_checks
        if checks is None:
            return
        found = checks.value(where, param.kind, value, mark) if param.kind else []
        if not found and param.type not in ("str", "str_list"):
            found = checks.unbound(where, value, mark)
        for error in found:
            if error.file == str(ctx.file) or error.file is None:
                self.error(error.message, mark, ctx)
            else:  # at the profile's line
                self.errors.append(error)

    # --------------------------------------------------------------- includes

    def include(
        self,
        spec: Any,
        type_mark: Mark | None,
        spec_mark: Mark | None,
        ctx: _Context,
        parent: str,
        siblings: Counter,
        name: str | None,
    ) -> py_trees.behaviour.Behaviour | None:
        if not isinstance(spec, MarkedDict):
            self.error(
                "subtree takes {file: TREE.yaml, with: {param: value}, name: ...}", spec_mark, ctx
            )
            return None
        ok = True
        for key in spec:
            if key not in SUBTREE_KEYS:
                self.error(
                    f"subtree has no option {shown(key)}{did_you_mean(str(key), SUBTREE_KEYS)}",
                    spec.key_mark(key),
                    ctx,
                )
                ok = False
        file = substitute(spec.get("file"), ctx.params)
        file_mark = spec.value_mark("file")
        if not isinstance(file, str) or not file:
            self.error("subtree needs file: the tree file to include", spec.mark, ctx)
            return None
        given = spec.get("with") or MarkedDict(mark=spec_mark)
        if not isinstance(given, MarkedDict):
            self.error(
                "subtree with: expected a mapping of parameter: value", spec.value_mark("with"), ctx
            )
            return None
        path = resolve(file, "tree", ctx.file.parent, base_first=True)
        if path is None:
            self.error(
                f"subtree file {shown(file)} not found next to {ctx.file.name}, in the working "
                f"directory or among the shipped trees{did_you_mean(Path(file).stem, available('tree'))}",
                file_mark,
                ctx,
            )
            return None
        if path in ctx.stack:
            cycle = " -> ".join(p.name for p in (*ctx.stack[ctx.stack.index(path) :], path))
            self.error(f"include cycle: {cycle}", file_mark, ctx)
            return None
        if len(ctx.stack) >= MAX_INCLUDE_DEPTH:
            self.error(f"subtrees nested more than {MAX_INCLUDE_DEPTH} files deep", file_mark, ctx)
            return None
        data = self.parse(path)
        if data is None:
            return None
        namespace = ctx.namespace
        if "namespace" in spec:
            own = spec["namespace"]
            if not isinstance(own, str) or not re.fullmatch(r"[A-Za-z_]\w*", own):
                self.error(
                    f"subtree namespace: expected a name (letters, digits, _), got {shown(own)}",
                    spec.value_mark("namespace"),
                    ctx,
                )
                ok = False
            else:
                namespace = f"{namespace}/{own}" if namespace else own
        inner = _Context(
            file=path, stack=(*ctx.stack, path), included_from=type_mark, namespace=namespace
        )
        if not isinstance(data, MarkedDict):
            self.error(
                "an included tree file must be a mapping with a root node",
                getattr(data, "mark", None) or Mark(str(path), 1, 1),
                inner,
            )
            return None
        self.check_keys(data, inner)
        self.load_plugins(data, inner)
        try:
            self.registry = self.manager.registry
        except ConfigError as exc:
            self.errors.extend(exc.errors)
            return None
        values = {k: substitute(v, ctx.params, ctx.namespace) for k, v in given.items()}
        declared = self.params.declared(data, inner)
        if declared is None:
            used = placeholders(data.get("root"))
            for key in given:
                if key not in used:
                    self.error(
                        f"{path.name} does not use parameter {shown(key)} (no {{{key}}} in it)",
                        given.key_mark(key),
                        ctx,
                    )
                    ok = False
        inner.params = self.params.bind(declared, values, given, inner, type_mark)
        self.initial_blackboard(data, inner)
        if name is None and "name" in spec:
            holder = MarkedDict({"name": spec["name"]}, mark=spec.mark)
            holder.value_marks["name"] = spec.value_mark("name")
            name = self.node_name(holder, "subtree", ctx)
        if "root" not in data:
            self.error("the included tree has no root node", data.mark, inner)
            return None
        root = self.build(data["root"], data.value_mark("root"), inner, parent, siblings, name)
        return root if ok else None


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


def node_kind(factory: Any) -> str:
    """``"leaf"``, ``"composite"`` or ``"decorator"`` for a registered behaviour factory."""
    kind = getattr(factory, "KIND", None)
    if kind in (LEAF, COMPOSITE, DECORATOR):
        return kind
    if isinstance(factory, type):
        if issubclass(factory, py_trees.decorators.Decorator):
            return DECORATOR
        if issubclass(factory, py_trees.composites.Composite):
            return COMPOSITE
    return LEAF


def construct(factory: Any, name: str, params: dict[str, Any]) -> py_trees.behaviour.Behaviour:
    """Build one node: ``factory(name, **params)``; a plain py_trees behaviour gets its name
    the way its constructor takes it (``name=``, first argument, or set afterwards)."""
    how = name_argument(factory) if takes_signature_params(factory) else "positional"
    if how == "keyword":
        return factory(name=name, **params)
    if how == "positional":
        return factory(name, **params)
    behaviour = factory(**params)
    behaviour.name = name
    return behaviour


def is_bindable(factory: Any) -> bool:
    """True when the factory reads ``"{key}"`` bindings (armtree behaviours do)."""
    flag = getattr(factory, "bindable", None)
    if isinstance(flag, bool):
        return flag
    return isinstance(factory, type) and issubclass(factory, Behaviour)


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value


def _set_nested(target: dict[str, Any], keys: tuple[str, ...], value: Any) -> None:
    for key in keys[:-1]:
        child = target.get(key)
        if not isinstance(child, dict):
            child = {}
            target[key] = child
        target = child
    target[keys[-1]] = value
