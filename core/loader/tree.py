"""A loaded tree: the py_trees root plus what the runtime needs to run and report it."""

from __future__ import annotations

import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import py_trees

from armtree.api.views import ProfileView
from armtree.errors import Mark
from armtree.hooks.plugin_manager import PluginManager, Registry, get_plugin_manager


@dataclass(frozen=True)
class NodeInfo:
    """Where a node came from: its path in the tree (``"Load a ducky/pick"``),
    its node type, the YAML position of its definition and the parameters it
    was built with (children excluded; a ``"{key}"`` binding as a
    :class:`~armtree.config.params.Binding`), for views that show them."""

    path: str
    type: str
    mark: Mark | None
    params: dict[str, Any] = field(default_factory=dict, compare=False)


@dataclass
class Tree:
    """A validated tree ready to run.

    ``root`` is a py_trees behaviour; ``nodes`` maps each behaviour's ``id`` to
    its :class:`NodeInfo`; ``profile`` is the validated hardware profile
    (``None`` when the tree needs no rig); ``blackboard`` holds the initial
    values (the file's plus ``--set`` overrides); ``tick_hz`` is the tick rate;
    ``expect`` the outcomes the file declares (:class:`armtree.api.outcomes.predicates.Expectation`),
    judged on the world at the end of every run; ``task`` the instruction the file
    gives (``task:``), what a dataset episode of the run is labelled with ("" for none).
    """

    name: str
    root: py_trees.behaviour.Behaviour
    source: Path | None
    tick_hz: float = 20.0
    description: str = ""
    blackboard: dict[str, Any] = field(default_factory=dict)
    nodes: dict[uuid.UUID, NodeInfo] = field(default_factory=dict)
    profile: ProfileView | None = None
    plugins: list[str] = field(default_factory=list)
    manager: PluginManager | None = None
    expect: list[Any] = field(default_factory=list)
    task: str = ""

    @property
    def registry(self) -> Registry:
        """The components of the plugins it was loaded with (its ``plugins:``' without)."""
        return (self.manager or get_plugin_manager(self.plugins)).registry

    def info(self, behaviour: py_trees.behaviour.Behaviour) -> NodeInfo | None:
        """The source information of one behaviour of this tree."""
        return self.nodes.get(behaviour.id)
