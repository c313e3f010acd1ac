"""One node built from its YAML mapping: its type looked up among the registered
behaviours (a composite, decorator or leaf; a ``subtree`` is opened by
:mod:`armtree.loader.subtree_include`), its name and path, its options split from its
children, its parameters checked (:mod:`armtree.loader.node_params`), its children built,
then the py_trees behaviour constructed and its :class:`NodeInfo` recorded."""

from __future__ import annotations

import traceback as tb_module
from collections import Counter
from dataclasses import dataclass
from typing import Any

import py_trees

from armtree.api.factories import COMPOSITE, DECORATOR, LEAF, construct, node_kind
from armtree.config.yamlio import MarkedDict, MarkedList
from armtree.errors import ConfigError, Mark, did_you_mean, shown
from armtree.hooks.hook_calls import raised_at
from armtree.hooks.plugin_manager import Registry

from .load_context import LoadContext, LoadErrors
from .node_names import node_name
from .node_params import NodeParams, PendingNode
from .subtree_include import SubtreeIncludes
from .tree import NodeInfo

#: Most nodes one tree may build, its subtrees included (ten subtrees of ten subtrees
#: of ... would otherwise multiply without bound).
MAX_NODES = 20_000

#: What each kind of node takes, for the error when it is given something else.
_TAKES = {
    COMPOSITE: "a list of children or a mapping with children",
    DECORATOR: "a mapping with child and its options",
    LEAF: "a mapping of its parameters",
}


def constructor_failure(component: Any, exc: BaseException) -> str:
    """What a behaviour's constructor raised, for the node's error: the exception's type
    and text, the class, and the plugin's file and line it was raised at."""
    factory = component.factory
    what = getattr(factory, "__qualname__", None) or type(factory).__name__
    file, line = raised_at(exc, factory)
    where = f" at {file}:{line}" if file else ""
    return (
        f"the constructor of {what} (plugin {component.plugin!r}) raised "
        f"{type(exc).__name__}{where}: {exc}"
    )


@dataclass(kw_only=True)
class NodeBuilder:
    """Checks and builds the nodes of one load, reporting problems to ``errors``.

    Node types are looked up in :attr:`registry` (the loader sets a new one when an
    included file loads plugins), parameters checked by ``params``, subtrees opened
    by ``includes``; every node built gets its :class:`NodeInfo` in ``nodes``.
    """

    registry: Registry
    errors: LoadErrors
    params: NodeParams
    includes: SubtreeIncludes
    nodes: dict[Any, NodeInfo]
    #: Nodes checked so far, subtrees' included.
    count: int = 0

    def build(
        self,
        value: Any,
        mark: Mark | None,
        ctx: LoadContext,
        parent: str,
        siblings: Counter,
        name: str | None = None,
    ) -> py_trees.behaviour.Behaviour | None:
        """Check one node and, when it and its children are valid, build it."""
        error = self.errors.error
        self.count += 1
        if self.count > MAX_NODES:
            if self.count == MAX_NODES + 1:
                error(
                    f"the tree has more than {MAX_NODES:,} nodes with its subtrees included; "
                    "is a subtree included inside itself many times over?",
                    getattr(value, "mark", None) or mark,
                    ctx,
                )
            return None
        if not isinstance(value, MarkedDict) or len(value) != 1:
            got = list(value) if isinstance(value, dict) else value
            error(
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
            included = self.includes.open(spec, type_mark, spec_mark, ctx, name)
            if included is None:
                return None
            root = self.build(
                included.root, included.mark, included.ctx, parent, siblings, included.name
            )
            return root if included.ok else None
        if not isinstance(ntype, str) or not self.registry.has("behaviour", ntype):
            known = self.registry.names("behaviour") + ["subtree"]
            why = self.registry.why_unknown("behaviour", str(ntype))
            error(
                f"unknown node type {shown(ntype)}{did_you_mean(str(ntype), known)}{why}",
                type_mark,
                ctx,
            )
            self._check_orphans(spec, spec_mark, ctx, parent)
            return None
        component = self.registry.get("behaviour", ntype)
        factory = component.factory
        kind = node_kind(factory)
        split = self._split(ntype, kind, spec, spec_mark, ctx)
        if split is None:
            return None
        options, children_spec, children_mark = split
        own_name = name or node_name(options, ntype, ctx, self.errors)
        options.pop("name", None)
        siblings[own_name] += 1
        path = f"{parent}/{own_name}" if parent else own_name
        if siblings[own_name] > 1:
            path += f"#{siblings[own_name]}"
        node = PendingNode(ntype, type_mark, own_name, path)
        params = self.params.check(factory, options, node, ctx)
        self.params.needs(ntype, factory, params, type_mark, ctx)
        built_children: Any = None
        if kind == COMPOSITE:
            built_children = self._build_children(children_spec, children_mark, ctx, path)
        elif kind == DECORATOR and children_spec is not None:
            built_children = self.build(children_spec, children_mark, ctx, path, Counter())
        if params is None or (kind != LEAF and built_children is None):
            return None
        if kind == COMPOSITE:
            params["children"] = built_children
        elif kind == DECORATOR:
            params["child"] = built_children
        try:
            behaviour = construct(factory, own_name, params)
        except ConfigError as exc:  # the behaviour's own word on its parameters
            error(f"{ntype} {shown(own_name)}: {exc.message}", type_mark, ctx)
            return None
        except Exception as exc:  # noqa: BLE001 - a plugin's constructor error is shown at the node
            text = f"{ntype} {shown(own_name)}: {constructor_failure(component, exc)}"
            error(text, type_mark, ctx, traceback="".join(tb_module.format_exception(exc)))
            return None
        given = {k: v for k, v in params.items() if k not in ("children", "child")}
        self.nodes[behaviour.id] = NodeInfo(path, ntype, type_mark, given)
        self._adopt(behaviour, path, ntype, type_mark)
        return behaviour

    def _split(
        self, ntype: str, kind: str, spec: Any, spec_mark: Mark | None, ctx: LoadContext
    ) -> tuple[MarkedDict, Any, Mark | None] | None:
        """A node's spec as (options, children's spec, where they are); None after an error."""
        error = self.errors.error
        if kind == COMPOSITE and isinstance(spec, MarkedList):
            return MarkedDict(mark=spec_mark), spec, spec_mark
        if spec is None and kind == LEAF:
            return MarkedDict(mark=spec_mark), None, spec_mark
        if not isinstance(spec, MarkedDict):
            error(f"{ntype} takes {_TAKES[kind]}; got {shown(spec)}", spec_mark, ctx)
            return None
        options = MarkedDict(spec, mark=spec.mark)
        options.key_marks, options.value_marks = spec.key_marks, spec.value_marks
        children_spec: Any = None
        children_mark = spec_mark
        if kind == COMPOSITE:
            if "children" not in spec:
                error(f"{ntype} needs children: a list of nodes", spec_mark, ctx)
            children_spec = options.pop("children", MarkedList(mark=spec_mark))
            children_mark = spec.value_mark("children")
        elif kind == DECORATOR:
            if "child" not in spec:
                error(f"{ntype} needs a child node (child: {{...}})", spec_mark, ctx)
            elif spec["child"] is None:
                error(
                    f"{ntype}: child is empty; give it a node (child: {{...}})",
                    spec.value_mark("child") or spec.key_mark("child"),
                    ctx,
                )
            children_spec = options.pop("child", None)
            children_mark = spec.value_mark("child")
        return options, children_spec, children_mark

    def _adopt(self, behaviour: Any, path: str, ntype: str, mark: Mark | None) -> None:
        """Give node info to behaviours a factory made inside itself (idioms, skill subtrees)."""
        for child in behaviour.children:
            if child.id not in self.nodes:
                child_path = f"{path}/{child.name}"
                self.nodes[child.id] = NodeInfo(child_path, ntype, mark)
                self._adopt(child, child_path, ntype, mark)

    def _build_children(
        self, spec: Any, mark: Mark | None, ctx: LoadContext, path: str
    ) -> list | None:
        if not isinstance(spec, MarkedList):
            self.errors.error(f"children: expected a list of nodes, got {shown(spec)}", mark, ctx)
            return None
        siblings: Counter = Counter()
        built = [
            self.build(child, spec.item_mark(i), ctx, path, siblings)
            for i, child in enumerate(spec)
        ]
        return None if any(b is None for b in built) else built

    def _check_orphans(self, spec: Any, mark: Mark | None, ctx: LoadContext, parent: str) -> None:
        """Check the children of a node of unknown type, so their errors are reported too."""
        if isinstance(spec, MarkedList):
            self._build_children(spec, mark, ctx, parent)
        elif isinstance(spec, MarkedDict):
            if isinstance(spec.get("children"), MarkedList):
                self._build_children(spec["children"], spec.value_mark("children"), ctx, parent)
            if isinstance(spec.get("child"), MarkedDict):
                self.build(spec["child"], spec.value_mark("child"), ctx, parent, Counter())
