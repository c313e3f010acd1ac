"""Registration of the built-in planners (``direct``, ``prm``) and the ``workspace`` command."""

from __future__ import annotations

from typing import Any

import armtree

from .direct import direct_factory
from .prm import prm_factory
from .workspace_command import WorkspaceCommand


@armtree.hookimpl
def armtree_planners() -> dict[str, Any]:
    """The built-in motion planners."""
    return {"direct": direct_factory, "prm": prm_factory}


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """``armtree workspace``."""
    return {"workspace": WorkspaceCommand()}
