"""``run-tree TREE --groot2 [PORT]``: one run served to Groot2 (:mod:`.groot2`), its tree and
statuses from :mod:`.monitor_tree`, its blackboard from py_trees' (one per process)."""

from __future__ import annotations

import uuid
from typing import Any

from py_trees.blackboard import Blackboard

from armtree.runtime.runlog import jsonable
from armtree.runtime.runner import Run

from .groot2 import Groot2Server
from .monitor_tree import MonitorTree

#: Where a run keeps its Groot2 session (``run.plugin_state``).
KEY = "btcpp.groot2"


class Groot2Session:
    """A run's Groot2 server and the tree it serves; :meth:`tick` after every tick."""

    def __init__(self, run: Run, port: int) -> None:
        self.run = run
        self.tree: MonitorTree | None = None
        self.server = Groot2Server(port, self.blackboard)

    def start(self) -> None:
        """Publish the tree and its statuses, and start answering."""
        self.reindex()
        self.server.start()

    def reindex(self) -> None:
        """Describe the run's (new) tree; Groot2 sees a new tree id and asks for it again."""
        self.tree = MonitorTree(self.run)
        self.tree.update(self.run.statuses)
        self.server.tree_xml, self.server.status = self.tree.xml, self.tree.status
        self.server.tree_id = uuid.uuid4().bytes

    def tick(self) -> None:
        """Publish this tick's statuses (nothing to do when none changed)."""
        tree = self.tree
        if tree is not None and tree.update(self.run.statuses):
            self.server.status = tree.status

    def blackboard(self, names: list[str]) -> dict[str, Any]:
        """``{name: {key: value}}``: the tree's name (or none) gives every key, a subtree
        namespace its own keys; names that are neither are left out, as BT.CPP does."""
        storage = dict(Blackboard.storage)
        tree_name = self.tree.name if self.tree is not None else ""
        out: dict[str, Any] = {}
        for name in [n for n in names if n] or [tree_name]:
            if name == tree_name:
                out[name] = {k.lstrip("/"): jsonable(v) for k, v in storage.items()}
                continue
            prefix = f"/{name.strip('/')}/"
            entries = {
                k[len(prefix) :]: jsonable(v) for k, v in storage.items() if k.startswith(prefix)
            }
            if entries:
                out[name] = entries
        return out

    def close(self) -> None:
        """Stop serving."""
        self.server.close()
