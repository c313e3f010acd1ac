"""BehaviorTree.CPP v4 XML read as the data a YAML tree file gives, every position kept.

One ``<BehaviorTree ID>`` becomes one tree file's mapping (``tree:``, ``root:``): the
file's main tree (``main_tree_to_execute``, else the one tree no ``SubTree`` includes,
else the first), or tree ``ID`` for a path ``FILE.xml#ID``. Nodes become one-key
mappings: BT.CPP's built-ins through :mod:`.mapping`, any other element (compact
``<look .../>`` or explicit ``<Action ID="look"/>``) is the armtree node type of its
ID, its attributes its parameters (:mod:`.values`); ``<SubTree ID="search"
tag="duckybot"/>`` is ``subtree: {file: "#search", with: {tag: duckybot}}``, shared
blackboard with ``_autoremap="true"``, else in a namespace of its own (``_namespace``,
else its name or ID). armtree's own top-level keys travel as ``_description``,
``_rig``, ``_tick_hz``, ``_blackboard``, ``_expect`` and ``_plugins`` attributes of
``<BehaviorTree>`` (BT.CPP ignores them), and ``_tree``, the tree's name where its ID
had to differ (a tree named like a node, see :func:`.writer.tree_id`); a tree's
``params:`` as the ports of its ``<SubTree ID>`` model in ``<TreeNodesModel>``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from armtree import ConfigError
from armtree.config.yamlio import MarkedDict, MarkedList, error_at
from armtree.errors import Mark, shown
from armtree.hooks.plugin_manager import get_plugin_manager

from .mapping import BY_BTCPP, SCRIPT_ATTRIBUTES, UNMATCHED
from .values import PORT_TYPES, from_port
from .xmlfile import Element, parse_xml_file

#: Element names that say the node's kind and take its type from ``ID``.
EXPLICIT = {"Action": "leaf", "Condition": "leaf", "Control": "composite", "Decorator": "decorator"}
#: Attributes that are not ports.
RESERVED = frozenset({"name", "ID", "_autoremap", "_uid", "_fullpath", "_namespace"})
#: armtree's top-level keys carried by ``<BehaviorTree>`` attributes (``_KEY``), and
#: whether the value is text (else YAML).
TREE_KEYS = {
    "description": True,
    "rig": True,
    "tick_hz": False,
    "blackboard": False,
    "expect": False,
    "plugins": False,
}


@dataclass
class PortModel:
    """One port of a ``<TreeNodesModel>`` entry."""

    name: str
    direction: str
    type: str | None
    default: str | None
    doc: str
    element: Element


@dataclass
class NodeModel:
    """One ``<TreeNodesModel>`` entry: kind (Action, Condition, Control, Decorator,
    SubTree) and ports by name."""

    kind: str
    ports: dict[str, PortModel] = field(default_factory=dict)
    element: Element | None = None


def read_tree(path: Path) -> MarkedDict | None:
    """The tree file data of ``path`` (``FILE.xml`` or ``FILE.xml#ID``), or None when it is
    not an XML file; :class:`ConfigError` listing every problem, each at its position."""
    name, _, tree_id = path.name.partition("#")
    real = path.with_name(name)
    if real.suffix.lower() != ".xml":
        return None
    document = XmlDocument(parse_xml_file(real), str(real))
    data = document.tree(tree_id) if document.ok else None
    if document.errors:
        first = document.errors[0]
        raise ConfigError(first.message, first.file, first.line, first.column, document.errors)
    return data


class XmlDocument:
    """One BT.CPP XML file: its trees and node models; :meth:`tree` converts one."""

    def __init__(self, root: Element, file: str) -> None:
        self.file = file
        self.errors: list[ConfigError] = []
        self.trees: dict[str, Element] = {}
        self.models: dict[str, NodeModel] = {}
        self.root = root
        self.ok = self._read_root(root)

    def error(self, message: str, mark: Mark | None) -> None:
        """Record a problem at ``mark``."""
        self.errors.append(error_at(message, mark, self.file))

    # ------------------------------------------------------------------
    # The document
    # ------------------------------------------------------------------

    def _read_root(self, root: Element) -> bool:
        if root.tag != "root":
            self.error(
                f'a BehaviorTree.CPP file\'s outer element is <root BTCPP_format="4">, '
                f"not <{root.tag}>",
                root.mark,
            )
            return False
        version = root.attrs.get("BTCPP_format", "4").strip()
        if version != "4":
            self.error(
                f"BTCPP_format={version}: armtree reads BehaviorTree.CPP 4 files; "
                'convert it with Groot2 or write BTCPP_format="4"',
                root.value_mark("BTCPP_format"),
            )
            return False
        unnamed = 0
        for child in root.children:
            if child.tag == "BehaviorTree":
                tree_id = child.attrs.get("ID")
                if tree_id is None:
                    unnamed += 1
                    tree_id = f"BehaviorTree_{unnamed - 1}"
                if tree_id in self.trees:
                    first = self.trees[tree_id].mark
                    self.error(
                        f"<BehaviorTree ID={shown(tree_id)}> is defined twice (first at line "
                        f"{first.line}); give each tree its own ID",
                        child.value_mark("ID"),
                    )
                self.trees.setdefault(tree_id, child)
            elif child.tag == "TreeNodesModel":
                self._read_models(child)
            elif child.tag == "include":
                self.error(
                    "<include> is not read by armtree: put the trees in this file, or keep "
                    "each in its own file and include it with a SubTree of armtree's YAML",
                    child.mark,
                )
            else:
                self.error(
                    f"<{child.tag}> is not a BehaviorTree.CPP element here: <root> holds "
                    "<BehaviorTree> and <TreeNodesModel>",
                    child.mark,
                )
        if unnamed and len(self.trees) > 1:
            self.error("every <BehaviorTree> of a file with several needs an ID", root.mark)
        if not self.trees:
            self.error("the file has no <BehaviorTree>", root.mark)
        return not self.errors

    def _read_models(self, models: Element) -> None:
        for entry in models.children:
            node_id = entry.attrs.get("ID")
            if node_id is None:
                self.error(f"<{entry.tag}> in <TreeNodesModel> needs an ID", entry.mark)
                continue
            if node_id in self.models:
                first = self.models[node_id].element
                where = f" (first at line {first.mark.line})" if first is not None else ""
                self.error(
                    f"<{entry.tag} ID={shown(node_id)}> is described twice in <TreeNodesModel>"
                    f"{where}; keep one",
                    entry.value_mark("ID"),
                )
                continue
            model = NodeModel(entry.tag, element=entry)
            for port in entry.children:
                if port.tag not in ("input_port", "output_port", "inout_port"):
                    continue
                name = port.attrs.get("name")
                if not name:
                    self.error(f"<{port.tag}> needs a name", port.mark)
                    continue
                doc = port.text.strip() or port.attrs.get("description", "")
                model.ports[name] = PortModel(
                    name,
                    port.tag.split("_")[0],
                    port.attrs.get("type"),
                    port.attrs.get("default"),
                    doc,
                    port,
                )
            self.models[node_id] = model

    def main_id(self) -> str:
        """The tree run when the file is run: ``main_tree_to_execute``, else the one tree
        no SubTree includes, else the first."""
        main = self.root.attrs.get("main_tree_to_execute")
        if main is not None:
            if main not in self.trees:
                self.error(
                    f"main_tree_to_execute={shown(main)} names no <BehaviorTree> of the file "
                    f"(it has {', '.join(map(repr, self.trees))})",
                    self.root.value_mark("main_tree_to_execute"),
                )
            return main
        included = {
            e.attrs.get("ID")
            for tree in self.trees.values()
            for e in _walk(tree)
            if e.tag == "SubTree"
        }
        top = [tree_id for tree_id in self.trees if tree_id not in included]
        return top[0] if len(top) == 1 else next(iter(self.trees))

    # ------------------------------------------------------------------
    # One tree
    # ------------------------------------------------------------------

    def tree(self, tree_id: str) -> MarkedDict | None:
        """Tree ``tree_id`` (the main one when empty) as a tree file's mapping."""
        tree_id = tree_id or self.main_id()
        element = self.trees.get(tree_id)
        if element is None:
            if not self.errors:
                self.error(f"no <BehaviorTree ID={shown(tree_id)}> in the file", self.root.mark)
            return None
        data = MarkedDict(mark=element.mark)
        # a tree named like a node is written NAME_tree, its armtree name in _tree
        name_attr = "_tree" if "_tree" in element.attrs else "ID"
        data["tree"] = element.attrs.get("_tree", tree_id)
        data.key_marks["tree"] = element.name_mark(name_attr)
        data.value_marks["tree"] = element.value_mark(name_attr)
        for key, text in TREE_KEYS.items():
            attr = f"_{key}"
            if attr in element.attrs:
                value = element.attrs[attr]
                mark = element.value_mark(attr)
                data[key] = value if text else from_port(value, attr, None, mark)
                data.key_marks[key] = element.name_mark(attr)
                data.value_marks[key] = mark
        params = self._params(tree_id)
        if params is not None:
            data["params"] = params
            # _params marks the mapping at its first port's element, a Mark
            assert params.mark is not None
            data.key_marks["params"] = data.value_marks["params"] = params.mark
        if len(element.children) != 1:
            self.error(
                f"<BehaviorTree ID={shown(tree_id)}> holds exactly one node, its root; it has "
                f"{len(element.children)}",
                element.mark,
            )
            return data
        root = element.children[0]
        data["root"] = self.node(root)
        data.key_marks["root"] = data.value_marks["root"] = root.mark
        return data

    def _params(self, tree_id: str) -> MarkedDict | None:
        """A tree's ``params:`` from the ports of its ``<SubTree ID>`` model."""
        model = self.models.get(tree_id)
        if model is None or model.kind != "SubTree" or not model.ports:
            return None
        params = MarkedDict(mark=next(iter(model.ports.values())).element.mark)
        for port in model.ports.values():
            entry = MarkedDict(mark=port.element.mark)
            if port.default is not None:
                mark = port.element.value_mark("default")
                entry["default"] = from_port(port.default, port.name, port.type, mark)
                entry.key_marks["default"] = port.element.name_mark("default")
                entry.value_marks["default"] = mark
            if port.doc:
                entry["doc"] = port.doc
                entry.key_marks["doc"] = entry.value_marks["doc"] = port.element.mark
            params[port.name] = entry
            params.key_marks[port.name] = port.element.value_mark("name")
            params.value_marks[port.name] = port.element.mark
        return params

    def node(self, element: Element) -> MarkedDict | None:
        """One node element as a one-key mapping ``{type: spec}``; None after an error."""
        for attr in element.attrs:
            if attr in SCRIPT_ATTRIBUTES:
                self.error(
                    f"{attr}: BehaviorTree.CPP's scripts are not run by armtree; express the "
                    "condition with nodes (a selector, a check_blackboard_variable_value)",
                    element.name_mark(attr),
                )
        if element.tag == "SubTree":
            return self._subtree(element)
        kind = EXPLICIT.get(element.tag)
        if kind is not None:
            node_id = element.attrs.get("ID")
            if not node_id:
                self.error(f"<{element.tag}> needs an ID: the node type", element.mark)
                return None
        else:
            node_id = element.tag
        if node_id in UNMATCHED:
            self.error(
                f"BehaviorTree.CPP's {node_id} has no armtree counterpart: {UNMATCHED[node_id]}",
                element.mark,
            )
            return None
        builtin = BY_BTCPP.get(node_id)
        spec = MarkedDict(mark=element.mark)
        if builtin is not None:
            ntype, kind = builtin.armtree, builtin.kind
            ports = {k: v for k, v in element.attrs.items() if _is_port(k)}
            unknown = [port for port in ports if port not in builtin.ports]
            for port in unknown:
                takes = ", ".join(builtin.ports) or "no ports"
                self.error(
                    f"{node_id} has no port {shown(port)} (it takes {takes})",
                    element.name_mark(port),
                )
            if unknown:
                return None
            try:
                options = builtin.read(ports)
            except ValueError as exc:
                self.error(f"{node_id}: {exc}", element.mark)
                return None
            mark = element.value_mark(next(iter(ports))) if ports else element.mark
            for key, value in options.items():
                spec[key] = value
                spec.key_marks[key] = spec.value_marks[key] = mark
        else:
            ntype = node_id
            model = self.models.get(node_id)
            if kind is None and model is not None:
                kind = {"Control": "composite", "Decorator": "decorator"}.get(model.kind, "leaf")
            self._ports(element, model, spec)
        self._name(element, spec)
        self._children(element, node_id, kind, spec)
        node = MarkedDict({ntype: spec}, mark=element.mark)
        node.key_marks[ntype] = element.mark
        node.value_marks[ntype] = element.mark
        return node

    def _ports(self, element: Element, model: NodeModel | None, spec: MarkedDict) -> None:
        if model is not None:
            types = {name: port.type for name, port in model.ports.items()}
        else:
            types = registered_port_types(element.tag)
        for attr, text in element.attrs.items():
            if not _is_port(attr):
                continue
            mark = element.value_mark(attr)
            spec[attr] = from_port(text, attr, types.get(attr), mark)
            spec.key_marks[attr] = element.name_mark(attr)
            spec.value_marks[attr] = mark

    def _name(self, element: Element, spec: MarkedDict) -> None:
        if "name" in element.attrs:
            spec["name"] = element.attrs["name"]
            spec.key_marks["name"] = element.name_mark("name")
            spec.value_marks["name"] = element.value_mark("name")

    def _children(self, element: Element, node_id: str, kind: str | None, spec: MarkedDict) -> None:
        children = element.children
        if kind == "leaf" and children:
            self.error(
                f"{node_id} is a leaf (an Action or Condition): it takes no child nodes",
                children[0].mark,
            )
            return
        if kind == "decorator" or (kind is None and len(children) == 1):
            if len(children) > 1:
                self.error(
                    f"{node_id} is a decorator: it takes one child node, not {len(children)}",
                    children[1].mark,
                )
            if children:
                spec["child"] = self.node(children[0])
                spec.key_marks["child"] = spec.value_marks["child"] = children[0].mark
            return
        if kind == "composite" or children:
            nodes_mark = children[0].mark if children else element.mark
            nodes = MarkedList(mark=nodes_mark)
            for child in children:
                nodes.append(self.node(child))
                nodes.item_marks.append(child.mark)
            spec["children"] = nodes
            spec.key_marks["children"] = spec.value_marks["children"] = nodes_mark

    def _subtree(self, element: Element) -> MarkedDict:
        """``<SubTree ID=...>`` as a ``subtree:`` node including tree ``#ID`` of this file."""
        tree_id = element.attrs.get("ID", "")
        spec = MarkedDict(mark=element.mark)
        spec["file"] = f"#{tree_id}"
        spec.key_marks["file"] = element.name_mark("ID")
        spec.value_marks["file"] = element.value_mark("ID")
        if not tree_id:
            self.error("<SubTree> needs an ID: the <BehaviorTree> it includes", element.mark)
        elif tree_id not in self.trees:
            self.error(
                f"<SubTree ID={shown(tree_id)}>: the file has no <BehaviorTree ID="
                f"{shown(tree_id)}> (it has {', '.join(map(repr, self.trees))})",
                element.value_mark("ID"),
            )
        model = self.models.get(tree_id)
        given = MarkedDict(mark=element.mark)
        for attr, text in element.attrs.items():
            if _is_port(attr):
                port = model.ports.get(attr) if model is not None else None
                mark = element.value_mark(attr)
                given[attr] = from_port(text, attr, port.type if port is not None else None, mark)
                given.key_marks[attr] = element.name_mark(attr)
                given.value_marks[attr] = mark
        if given:
            spec["with"] = given
            spec.key_marks["with"] = spec.value_marks["with"] = element.mark
        self._name(element, spec)
        if element.attrs.get("_autoremap", "false").strip().lower() != "true":
            own = element.attrs.get("_namespace") or element.attrs.get("name") or tree_id
            spec["namespace"] = re.sub(r"^(?=\d)", "_", re.sub(r"\W", "_", own)) or "_"
            where = "_namespace" if "_namespace" in element.attrs else "ID"
            spec.key_marks["namespace"] = element.name_mark(where)
            spec.value_marks["namespace"] = element.value_mark(where)
        node = MarkedDict({"subtree": spec}, mark=element.mark)
        node.key_marks["subtree"] = node.value_marks["subtree"] = element.mark
        return node


def registered_port_types(node_id: str) -> dict[str, str | None]:
    """The port types of the registered behaviour ``node_id`` (armtree's own and installed
    plugins'), for a file whose ``<TreeNodesModel>`` does not describe it; ``{}`` for a
    name nothing registers (the loader names it)."""
    registry = get_plugin_manager().registry
    if not registry.has("behaviour", node_id):
        return {}
    params = registry.get("behaviour", node_id).params
    return {param.name: PORT_TYPES.get(param.type) for param in params}


def _is_port(attr: str) -> bool:
    """BT.CPP's rule: a port's name starts with a letter and is not reserved."""
    return bool(attr) and attr[0].isalpha() and attr not in RESERVED


def _walk(element: Element) -> list[Element]:
    """Every element under ``element``, without recursion."""
    found, todo = [], list(element.children)
    while todo:
        current = todo.pop()
        found.append(current)
        todo.extend(current.children)
    return found
