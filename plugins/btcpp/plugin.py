"""The BehaviorTree.CPP plugin's hooks: XML tree files, ``armtree export``, ``--groot2``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import armtree

from .reader import read_tree


@armtree.hookimpl
def armtree_read_tree(path: Path) -> Any:
    """BehaviorTree.CPP v4 XML (``.xml``) as tree file data."""
    return read_tree(path)


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """``armtree export``."""
    from .export_command import ExportCommand

    return {"export": ExportCommand()}
