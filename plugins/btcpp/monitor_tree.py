"""A running tree as Groot2 sees it: the tree as XML with each node's ``_uid``, and every
node's status as the Groot2 protocol's status buffer.

Node ``uid`` is the node's place in the tree, parents first, plus one, as
BehaviorTree.CPP numbers its nodes. Subtrees appear inlined, as armtree runs them,
in one ``<BehaviorTree>``; each node carries ``_fullpath``, its path in the run log.
Statuses are BT.CPP's codes: IDLE 0, RUNNING 1, SUCCESS 2, FAILURE 3, and 10 plus
the last status for a node that went idle after running (Groot2 shows it faded).
"""

from __future__ import annotations

import struct
import xml.etree.ElementTree as ET
from typing import Any

from armtree.loader.tree import Tree
from armtree.runtime.runner import Run

from .mapping import exported
from .values import PORT_TYPES, is_text_type, to_port
from .writer import model_element

#: py_trees status names as BT.CPP status codes; INVALID is idle (see :func:`next_codes`).
CODES = {"RUNNING": 1, "SUCCESS": 2, "FAILURE": 3}


class MonitorTree:
    """The tree of one run: its XML once, its status buffer after each tick."""

    def __init__(self, run: Run) -> None:
        self.nodes = list(run.nodes)
        tree = run.tree
        order = _preorder(tree.root)
        self.uids = {id(node): i + 1 for i, node in enumerate(order)}
        paths = dict(zip(map(id, self.nodes), run.node_paths, strict=True))
        self.name = str(tree.name)
        self.xml = _tree_xml(tree, order, paths, self.uids).encode("utf-8")
        self.codes = [0] * len(self.nodes)
        # one entry per node in run.statuses' order, so a tick's statuses go in by slicing
        self._buffer = bytearray(
            b"".join(struct.pack("<HB", self.uids[id(node)], 0) for node in self.nodes)
        )
        self._last: Any = None
        #: The status buffer as last updated (an immutable copy another thread may send).
        self.status = bytes(self._buffer)

    def update(self, statuses: tuple[str, ...]) -> bool:
        """Take the statuses after a tick (``run.statuses``); True when any changed."""
        if statuses is self._last:
            return False
        self._last = statuses
        self.codes = codes = next_codes(statuses, self.codes)
        self._buffer[2::3] = bytes(codes)
        self.status = bytes(self._buffer)
        return True


def next_codes(statuses: tuple[str, ...], previous: list[int]) -> list[int]:
    """Each node's status code from its status name and its previous code: a node that
    turned INVALID after RUNNING, SUCCESS or FAILURE is 10 plus that code."""
    return [
        CODES.get(name) or (code + 10 if 0 < code < 10 else code)
        for name, code in zip(statuses, previous, strict=True)
    ]


def _preorder(root: Any) -> list[Any]:
    """The tree's nodes parents first, as BT.CPP creates (and numbers) them."""
    order, todo = [], [root]
    while todo:
        node = todo.pop()
        order.append(node)
        todo.extend(reversed(node.children))
    return order


def _tree_xml(tree: Tree, nodes: list[Any], paths: dict[int, str], uids: dict[int, int]) -> str:
    """The tree as BT.CPP's monitor writes it: ``<BehaviorTree>`` with ``_uid`` on every
    node, then the ``<TreeNodesModel>`` of its custom nodes."""
    registry = tree.manager.registry if tree.manager is not None else None
    root = ET.Element("root", BTCPP_format="4")
    behavior = ET.SubElement(root, "BehaviorTree", ID=str(tree.name), _fullpath="")
    used: dict[str, Any] = {}
    parents: dict[int, ET.Element] = {}
    infos = tree.nodes
    for node in nodes:
        info = infos.get(node.id)
        parent_node = node.parent
        parent_info = infos.get(parent_node.id) if parent_node is not None else None
        made_inside = info is None or (
            parent_info is not None
            and (info.type, info.mark) == (parent_info.type, parent_info.mark)
        )
        tag = type(node).__name__
        ports: dict[str, str] = {}
        # made_inside holds whenever info is None; the test says so to mypy
        if info is not None and not made_inside:
            options = {k: v for k, v in info.params.items() if v is not None}
            mapped = exported(info.type, options)
            if mapped is not None:
                tag, ports = mapped
            else:
                tag = info.type
                component = registry.get("behaviour", info.type) if registry else None
                types = (
                    {p.name: PORT_TYPES.get(p.type) for p in component.params} if component else {}
                )
                ports = {k: to_port(v, is_text_type(types.get(k))) for k, v in info.params.items()}
                if component is not None:
                    used[info.type] = component
        parent = parents.get(id(parent_node), behavior) if parent_node is not None else behavior
        element = ET.SubElement(parent, tag, name=node.name)
        element.set("_uid", str(uids[id(node)]))
        element.set("_fullpath", paths.get(id(node), node.name))
        for key, text in ports.items():
            element.set(key, text)
        parents[id(node)] = element
    models = ET.SubElement(root, "TreeNodesModel")
    for ntype in sorted(used):
        models.append(model_element(ntype, used[ntype]))
    ET.indent(root, "  ")
    return ET.tostring(root, encoding="unicode")
