"""A ``subtree:`` node's include: its options checked, its file found (next to the
including file, in the working directory, among the shipped trees), cycles and
over-deep chains refused, the file opened (its top-level keys and plugins) and its
parameters bound for this one instance, in its own blackboard namespace if it asks
for one. What it gives back, :class:`Included`, the node builder builds."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from armtree.config.resolve import available, not_a_file, resolve
from armtree.config.yamlio import MarkedDict
from armtree.errors import Mark, did_you_mean, shown

from .load_context import LoadContext, LoadErrors, TreeFiles
from .node_names import node_name
from .tree_keys import TreeKeys
from .tree_params import TreeParams, placeholders, substitute

#: Keys of a ``subtree`` node.
SUBTREE_KEYS = ("file", "with", "name", "namespace")
#: Deepest chain of subtree includes.
MAX_INCLUDE_DEPTH = 32

#: ``load_plugins(data, ctx)``: loads an included file's ``plugins:`` and refreshes the
#: registry its nodes are looked up in; False when that registry cannot be built.
LoadPlugins = Callable[[MarkedDict, LoadContext], bool]


@dataclass
class Included:
    """An included file ready to build: its root node in the context it builds in."""

    #: The file's ``root:`` value and where it was written.
    root: Any
    mark: Mark | None
    #: The included file, its bound parameters, the include chain and namespace.
    ctx: LoadContext
    #: The subtree's ``name:`` (None: the root's own name).
    name: str | None
    #: False when the include itself was wrong: its root is built, to report its
    #: errors too, but not used.
    ok: bool


@dataclass(kw_only=True)
class SubtreeIncludes:
    """Opens the files that ``subtree:`` nodes include, reporting problems to ``errors``.

    It parses through ``files`` (each file once per load), checks and reads the
    included file's top-level keys through ``tree_keys``, loads its plugins through
    ``load_plugins`` and binds its ``params:`` through ``params``.
    """

    files: TreeFiles
    errors: LoadErrors
    params: TreeParams
    tree_keys: TreeKeys
    load_plugins: LoadPlugins

    def open(
        self,
        spec: Any,
        type_mark: Mark | None,
        spec_mark: Mark | None,
        ctx: LoadContext,
        name: str | None,
    ) -> Included | None:
        """The file ``spec`` (a subtree node's mapping, written at ``spec_mark``) includes,
        ready to build; None when there is nothing to build (errors recorded)."""
        error = self.errors.error
        if not isinstance(spec, MarkedDict):
            error(
                "subtree takes {file: TREE.yaml, with: {param: value}, name: ...}", spec_mark, ctx
            )
            return None
        ok = self.errors.unknown_keys(spec, SUBTREE_KEYS, "subtree has no option", ctx)
        file = substitute(spec.get("file"), ctx.params)
        file_mark = spec.value_mark("file")
        if not isinstance(file, str) or not file:
            error("subtree needs file: the tree file to include", spec.mark, ctx)
            return None
        given = spec.get("with") or MarkedDict(mark=spec_mark)
        if not isinstance(given, MarkedDict):
            error(
                "subtree with: expected a mapping of parameter: value", spec.value_mark("with"), ctx
            )
            return None
        path = self._find(file, file_mark, ctx)
        if path is None:
            return None
        data = self.files.parse(path)
        if data is None:
            if not self.files.failed(path):
                error(
                    f"subtree file {path} is empty; it needs a root node (tree: NAME, root: ...)",
                    file_mark,
                    ctx,
                )
            return None
        namespace = ctx.namespace
        if "namespace" in spec:
            own = spec["namespace"]
            if not isinstance(own, str) or not re.fullmatch(r"[A-Za-z_]\w*", own):
                error(
                    f"subtree namespace: expected a name (letters, digits, _), got {shown(own)}",
                    spec.value_mark("namespace"),
                    ctx,
                )
                ok = False
            else:
                namespace = f"{namespace}/{own}" if namespace else own
        inner = LoadContext(
            file=path, stack=(*ctx.stack, path), included_from=type_mark, namespace=namespace
        )
        if not isinstance(data, MarkedDict):
            error(
                "an included tree file must be a mapping with a root node",
                getattr(data, "mark", None) or Mark(str(path), 1, 1),
                inner,
            )
            return None
        self.tree_keys.check(data, inner)
        if not self.load_plugins(data, inner):
            return None
        ok = self._bind(data, given, type_mark, ctx, inner) and ok
        self.tree_keys.initial_blackboard(data, inner)
        if name is None and "name" in spec:
            holder = MarkedDict({"name": spec["name"]}, mark=spec.mark)
            if (name_mark := spec.value_mark("name")) is not None:
                holder.value_marks["name"] = name_mark
            name = node_name(holder, "subtree", ctx, self.errors)
        if "root" not in data:
            error("the included tree has no root node", data.mark, inner)
            return None
        return Included(data["root"], data.value_mark("root"), inner, name, ok)

    def _find(self, file: str, mark: Mark | None, ctx: LoadContext) -> Path | None:
        """The file to include, or None after an error: not found, a cycle, too deep.

        ``FILE#ID`` names tree ``ID`` of a file holding several (BehaviorTree.CPP
        XML); ``#ID`` one of the including file. Its path is the file's with ``#ID``
        appended to the name, which the plugin that reads the format understands.
        """
        name, fragment, tree_id = file.partition("#")
        if name:
            path = resolve(name, "tree", ctx.file.parent, base_first=True)
        else:
            path = ctx.file.with_name(ctx.file.name.partition("#")[0])
        if path is not None and fragment:
            path = path.with_name(f"{path.name}#{tree_id}")
        if path is None:
            self.errors.error(
                f"subtree file {shown(file)} not found next to {ctx.file.name}, in the working "
                f"directory or among the shipped trees"
                f"{not_a_file(name, 'tree', ctx.file.parent, base_first=True)}"
                f"{did_you_mean(Path(file).stem, available('tree'))}",
                mark,
                ctx,
            )
            return None
        if path in ctx.stack:
            cycle = " -> ".join(p.name for p in (*ctx.stack[ctx.stack.index(path) :], path))
            self.errors.error(f"include cycle: {cycle}", mark, ctx)
            return None
        if len(ctx.stack) >= MAX_INCLUDE_DEPTH:
            self.errors.error(
                f"subtrees nested more than {MAX_INCLUDE_DEPTH} files deep", mark, ctx
            )
            return None
        return path

    def _bind(
        self,
        data: MarkedDict,
        given: MarkedDict,
        type_mark: Mark | None,
        ctx: LoadContext,
        inner: LoadContext,
    ) -> bool:
        """Bind the included file's parameters to ``with:`` (evaluated in the includer's
        ``ctx``) into ``inner``; False when ``with:`` gives one an undeclaring file lacks."""
        values = {k: substitute(v, ctx.params, ctx.namespace) for k, v in given.items()}
        declared = self.params.declared(data, inner)
        ok = True
        if declared is None:
            used = placeholders(data.get("root"))
            for key in given:
                if key not in used:
                    self.errors.error(
                        f"{inner.file.name} does not use parameter {shown(key)} (no {{{key}}} in it)",
                        given.key_mark(key),
                        ctx,
                    )
                    ok = False
        inner.params = self.params.bind(declared, values, given, inner, type_mark)
        return ok
