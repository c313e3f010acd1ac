"""The grip a pick hands to the release that follows, through the blackboard.

Data between skills goes through py_trees' blackboard, never through attributes set
on shared objects such as the Rig. A ``pick`` or ``grasp`` that gripped writes a
:class:`Held` to :data:`HELD_KEY`; the next ``place`` or ``release`` takes it (reads
and unsets it): where the held marker sits on the tool, so that the place check looks
where the object lands and a bin drop clears what lies under it. Both show in the
run log as ``blackboard`` records.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from py_trees.blackboard import Client
from py_trees.common import Access

#: Blackboard key of the grip the last pick or grasp made, until a release takes it.
HELD_KEY = "/skills/held"


@dataclass(frozen=True)
class Held:
    """What a grip left on the tool: the held marker's centre in the tool frame
    (homogeneous ``[x, y, z, 1]``, mm; None when the grip's pose was not computable),
    and how far the held object reaches below the tool centre (mm: the grip's height
    over the table it stood on; None without a table height)."""

    marker_in_tool: np.ndarray | None
    hang_mm: float | None


def hand_over(bb: Client) -> None:
    """Let blackboard client ``bb`` write :data:`HELD_KEY` (a skill that grips)."""
    bb.register_key(key=HELD_KEY, access=Access.WRITE)


def take_over(bb: Client) -> None:
    """Let blackboard client ``bb`` read and unset :data:`HELD_KEY` (a skill that lets go)."""
    bb.register_key(key=HELD_KEY, access=Access.WRITE)
    bb.register_key(key=HELD_KEY, access=Access.READ)


def take(bb: Client) -> Held | None:
    """The :class:`Held` the last grip wrote, unset so no later release takes it again;
    None when no grip handed one over."""
    if not bb.exists(HELD_KEY):
        return None
    held = bb.get(HELD_KEY)
    bb.unset(HELD_KEY)
    return held


__all__ = ["HELD_KEY", "Held", "hand_over", "take", "take_over"]
