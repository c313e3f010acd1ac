"""armtree trees written as BehaviorTree.CPP v4 XML, and the palette of every behaviour.

The tree is validated first (the loader's checks, against its rig), then written from
its files as written, so a subtree's parameters stay parameters: each file is one
``<BehaviorTree ID>`` (its ``tree:`` name, see :func:`tree_id`), the tree that
includes it a ``<SubTree ID>`` whose ports are its ``with:``. armtree's composites and decorators become BT.CPP's
own where the semantics match (:mod:`.mapping`), every other node keeps its armtree
name as a custom node; its parameters are its ports (:mod:`.values`). The
``<TreeNodesModel>`` describes every custom node the file uses (:func:`model_element`)
and each tree's ``params:`` as its ``<SubTree>`` model's ports. :mod:`.reader` reads
all of it back to the same tree.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from armtree import load_tree
from armtree.api.factories import node_kind
from armtree.config.params import Param
from armtree.config.resolve import resolve
from armtree.config.yamlio import load_yaml_file
from armtree.errors import ConfigError
from armtree.hooks.plugin_manager import Component, PluginManager, Registry

from .mapping import BTCPP_NODE_IDS, CONDITIONS, MODEL_KINDS, exported
from .reader import TREE_KEYS, read_tree
from .values import PORT_TYPES, port_text, to_port

#: How a parameter's ``io`` is written in a model.
PORT_ELEMENTS = {"in": "input_port", "out": "output_port", "inout": "inout_port"}


def export_tree(
    path_or_name: str | Path,
    manager: PluginManager,
    rig: str | None = None,
    overrides: Iterable[str] = (),
) -> str:
    """The tree ``path_or_name`` (YAML or XML) as BT.CPP v4 XML text.

    The tree is loaded first with ``rig`` and ``overrides`` (every check; a required
    parameter needs a value), so an invalid tree raises :class:`ConfigError` and
    nothing is written; the XML is written from the files as they are.
    """
    tree = load_tree(path_or_name, rig=rig, overrides=overrides, manager=manager)
    writer = TreeWriter(tree.registry)
    assert tree.source is not None
    main = writer.add_file(Path(tree.source))
    # BT.CPP's createTreeFromText and Groot2 open this tree; armtree reads it too
    writer.root.set("main_tree_to_execute", main)
    return writer.xml()


def palette(registry: Registry) -> str:
    """A ``<TreeNodesModel>`` of every registered behaviour, for Groot2's editor."""
    root = ET.Element("root", BTCPP_format="4")
    models = ET.SubElement(root, "TreeNodesModel")
    for name in registry.names("behaviour"):
        models.append(model_element(name, registry.get("behaviour", name)))
    return _text(root)


def model_element(ntype: str, component: Component) -> ET.Element:
    """The ``<TreeNodesModel>`` entry of one behaviour: its kind, ports (direction, BT.CPP
    type, default, description with its unit) and description."""
    kind = node_kind(component.factory)
    tag = MODEL_KINDS[kind]
    if kind == "leaf" and (ntype in CONDITIONS or getattr(component.factory, "CONDITION", False)):
        tag = "Condition"
    element = ET.Element(tag, ID=ntype)
    for param in component.params:
        port = ET.SubElement(element, PORT_ELEMENTS[param.io], name=param.name)
        port_type = PORT_TYPES.get(param.type)
        if port_type:
            port.set("type", port_type)
        if not param.required and param.default is not None:
            port.set("default", port_text(param.default, port_type))
        port.text = _port_doc(param)
    if component.summary:
        ET.SubElement(element, "description").text = component.summary
    return element


def taken_ids(registry: Registry) -> set[str]:
    """The IDs a ``<BehaviorTree>`` may not have: every node's a BT.CPP program may have
    registered (armtree's palette, BT.CPP's own nodes)."""
    return set(registry.names("behaviour")) | BTCPP_NODE_IDS


def tree_id(name: str, taken: Iterable[str]) -> str:
    """The ``<BehaviorTree ID>`` of the armtree tree ``name``: the name itself, or, when
    a node or another tree has it, ``NAME_tree`` (then ``NAME_tree_2`` ...). BT.CPP
    refuses a tree that has a registered node's name (``track.yaml`` is the tree
    ``track`` with the skill ``track`` in it); the writer carries the name in
    ``_tree`` and the reader reads it back as the tree's name."""
    taken = set(taken)
    if name not in taken:
        return name
    base = candidate = f"{name}_tree"
    n = 1
    while candidate in taken:
        n += 1
        candidate = f"{base}_{n}"
    return candidate


def _port_doc(param: Param) -> str:
    unit = f" [{param.unit}]" if param.unit else ""
    return f"{param.doc}{unit}".strip()


class TreeWriter:
    """Writes tree files as ``<BehaviorTree>`` elements, each file once, the first the main."""

    def __init__(self, registry: Registry) -> None:
        self.registry = registry
        self.taken = taken_ids(registry)
        self.root = ET.Element("root", BTCPP_format="4")
        #: Each file written and its tree's ID.
        self.ids: dict[Path, str] = {}
        #: The custom node types used, for the model.
        self.used: dict[str, Component] = {}
        #: Each tree's ``params:`` by ID, for its ``<SubTree>`` model.
        self.params: dict[str, dict[str, Any]] = {}

    def add_file(self, path: Path) -> str:
        """Write the tree of ``path`` (and the trees it includes); its ``<BehaviorTree>`` ID."""
        if path in self.ids:
            return self.ids[path]
        data = _tree_data(path)
        name = data.get("tree") if isinstance(data.get("tree"), str) else path.stem
        own = tree_id(name, self.taken | set(self.ids.values()))
        self.ids[path] = own
        element = ET.SubElement(self.root, "BehaviorTree", ID=own)
        if own != name:
            element.set("_tree", name)
        for key, text in TREE_KEYS.items():
            if data.get(key) is not None:
                element.set(
                    f"_{key}", str(data[key]).strip() if text else to_port(data[key], False)
                )
        if isinstance(data.get("params"), dict) and data["params"]:
            self.params[own] = data["params"]
        element.append(self.node(data["root"], path))
        return own

    def node(self, value: dict[str, Any], file: Path) -> ET.Element:
        """One node (a one-key mapping as the tree file has it) as an element."""
        ntype, spec = next(iter(value.items()))
        if ntype == "subtree":
            return self._subtree(spec, file)
        component = self.registry.get("behaviour", ntype)
        kind = node_kind(component.factory)
        options, children = _split(kind, spec)
        name = options.pop("name", None)
        mapped = exported(ntype, options)
        if mapped is not None:
            tag, ports = mapped
        else:
            tag = ntype
            self.used[ntype] = component
            types = {p.name: PORT_TYPES.get(p.type) for p in component.params}
            ports = {k: port_text(v, types.get(k)) for k, v in options.items()}
        element = ET.Element(tag)
        if name is not None:
            element.set("name", str(name))
        for key, text in ports.items():
            element.set(key, text)
        for child in children:
            element.append(self.node(child, file))
        return element

    def _subtree(self, spec: dict[str, Any], file: Path) -> ET.Element:
        name, _, fragment = str(spec["file"]).partition("#")
        path = resolve(name, "tree", file.parent, base_first=True) if name else _real(file)
        if path is None:
            raise ConfigError(f"subtree file {name!r} not found", file=str(file))
        if fragment:
            path = path.with_name(f"{path.name}#{fragment}")
        element = ET.Element("SubTree", ID=self.add_file(path))
        if spec.get("name") is not None:
            element.set("name", str(spec["name"]))
        for key, value in (spec.get("with") or {}).items():
            element.set(str(key), to_port(value, False))
        if spec.get("namespace"):
            element.set("_autoremap", "false")
            element.set("_namespace", str(spec["namespace"]))
        else:
            element.set("_autoremap", "true")
        return element

    def xml(self) -> str:
        """The document: the trees, then the model of what they use."""
        models = ET.SubElement(self.root, "TreeNodesModel")
        for ntype in sorted(self.used):
            models.append(model_element(ntype, self.used[ntype]))
        for tree_id, params in self.params.items():
            model = ET.SubElement(models, "SubTree", ID=tree_id)
            for key, declared in params.items():
                port = ET.SubElement(model, "input_port", name=str(key))
                declared = declared if isinstance(declared, dict) else {}
                if "default" in declared:
                    port.set("default", to_port(declared["default"], False))
                if declared.get("doc"):
                    port.text = str(declared["doc"])
        return _text(self.root)


def _tree_data(path: Path) -> Any:
    data = read_tree(path)
    return load_yaml_file(path) if data is None else data


def _real(path: Path) -> Path:
    return path.with_name(path.name.partition("#")[0])


def _split(kind: str, spec: Any) -> tuple[dict[str, Any], list[Any]]:
    """A node's options and children (as the loader splits them)."""
    if kind == "composite" and isinstance(spec, list):
        return {}, list(spec)
    options = dict(spec or {})
    if kind == "composite":
        return options, list(options.pop("children", None) or [])
    if kind == "decorator":
        child = options.pop("child", None)
        return options, [child] if child is not None else []
    return options, []


def _text(root: ET.Element) -> str:
    ET.indent(root, "  ")
    return ET.tostring(root, encoding="unicode") + "\n"
