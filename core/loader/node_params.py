"""One node's parameters checked against what its behaviour declares (``PARAMS`` or its
constructor's signature, through the plugins' factories): unknown ones with
did-you-mean, types and ranges, ``"{key}"`` blackboard bindings noted as reads and
writes, required ones given, defaults filled in; when a profile is known, the values
resolved against the rig and the behaviour's needs (``NEEDS``, ``RESOURCES``, its
workcell) checked on it (see :mod:`armtree.loader.tree_checks`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from armtree.api.behaviour import Behaviour
from armtree.config.constructor_params import declared_params
from armtree.config.params import Binding, Param, check_value
from armtree.config.yamlio import MarkedDict, plain
from armtree.errors import Mark, did_you_mean, shown

from .blackboard_use import BlackboardUse
from .load_context import LoadContext, LoadErrors
from .tree_checks import RigChecks
from .tree_params import BINDING, has_missing, substitute


@dataclass
class PendingNode:
    """What is known about one node while checking it."""

    type: str
    mark: Mark | None
    name: str
    path: str


def is_bindable(factory: Any) -> bool:
    """True when the factory reads ``"{key}"`` bindings (armtree behaviours do)."""
    flag = getattr(factory, "bindable", None)
    if isinstance(flag, bool):
        return flag
    return isinstance(factory, type) and issubclass(factory, Behaviour)


class NodeParams:
    """Checks nodes' parameters, reporting to ``errors`` and noting blackboard use in ``keys``;
    with ``rig_checks`` (a profile is known), values are resolved against the rig too."""

    def __init__(
        self, errors: LoadErrors, keys: BlackboardUse, rig_checks: RigChecks | None
    ) -> None:
        self._errors = errors
        self._keys = keys
        self._rig_checks = rig_checks

    def check(
        self, factory: Any, options: MarkedDict, node: PendingNode, ctx: LoadContext
    ) -> dict[str, Any] | None:
        """Validated parameters with defaults filled in, or None after recording errors."""
        error = self._errors.error
        declared = {p.name: p for p in declared_params(factory)}
        bindable = is_bindable(factory)
        writes = set(getattr(factory, "writes", ()))
        reads = set(getattr(factory, "reads", ()))
        before = len(self._errors)
        incomplete = False
        params: dict[str, Any] = {}
        for key, raw in options.items():
            mark = options.value_mark(key)
            param = declared.get(key)
            if param is None:
                hint = did_you_mean(str(key), [*declared, "name"])
                if not hint and not declared:
                    hint = f"; {node.type} takes no parameters"
                error(
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
                    error(
                        f"{node.type}.{key} cannot be bound to the blackboard; give a value",
                        mark,
                        ctx,
                    )
                    continue
                key_name = binding.group(1)
                params[key] = Binding(key_name)
                if param.io in ("out", "inout"):
                    self._keys.write(key_name)
                if param.io in ("in", "inout"):
                    self._keys.read(key_name, mark, ctx.included_from)
                continue
            if param.io == "out":
                error(
                    f'{node.type}.{key} is an output: give the blackboard key to write as "{{key}}"',
                    mark,
                    ctx,
                )
                continue
            if value is None and not param.required and param.default is None:
                params[key] = None
                continue
            try:
                params[key] = check_value(param, plain(value))
            except ValueError as exc:
                error(f"{node.type}.{key}: {exc}", mark, ctx)
                continue
            if key in writes and isinstance(value, str):
                self._keys.write(value)
            self.on_rig(f"{node.type}.{key}", param, params[key], mark, ctx)
            if key in reads:
                self._keys.read_named(value)
        for pname, param in declared.items():
            if pname in params or pname in options:
                continue
            if param.required:
                doc = f" ({param.doc})" if param.doc else ""
                error(f"{node.type} needs parameter {pname!r}{doc}", node.mark, ctx)
            else:
                params[pname] = param.default
                self.on_rig(
                    f"{node.type}.{pname} (its default)", param, param.default, node.mark, ctx
                )
        return params if len(self._errors) == before and not incomplete else None

    def on_rig(
        self, where: str, param: Param, value: Any, mark: Mark | None, ctx: LoadContext
    ) -> None:
        """A value resolved against the profile (see :mod:`armtree.loader.tree_checks`)."""
        checks = self._rig_checks
        if checks is None:
            return
        found = checks.value(where, param.kind, value, mark) if param.kind else []
        if not found and param.type not in ("str", "str_list"):
            found = checks.unbound(where, value, mark)
        for error in found:
            if error.file == str(ctx.file) or error.file is None:
                self._errors.error(error.message, mark, ctx)
            else:  # at the profile's line
                self._errors.extend([error])

    def needs(
        self,
        ntype: str,
        factory: Any,
        params: dict[str, Any] | None,
        mark: Mark | None,
        ctx: LoadContext,
    ) -> None:
        """The behaviour's rig needs (``NEEDS``, ``RESOURCES``, its workcell) against the profile."""
        if self._rig_checks is None:
            return
        # a behaviour whose workcell needs depend on its parameters says so through
        # workcell_for(params) (a sweep needs the survey region only with sweep: true)
        workcell_for = getattr(factory, "workcell_for", None)
        workcell = (
            workcell_for(params or {})
            if callable(workcell_for)
            else getattr(factory, "WORKCELL", ())
        )
        for error in self._rig_checks.needs(
            ntype,
            getattr(factory, "NEEDS", ()),
            getattr(factory, "RESOURCES", ()),
            mark,
            workcell,
        ):
            self._errors.error(error.message, mark, ctx)
