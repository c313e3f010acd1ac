"""Letting go into a bin: where across its inside, and how high, given what is already in it.

A profile's ``workcell.bins`` gives a container at a place: its inside (``size_mm``,
centred on the place) and its rim's height. Dropping every object at the place
itself stacks them, and an arm that reaches only a few centimetres above the bin
(a Dobot V1.0) then presses the next one into the stack. So each release lands
where the inside is emptiest: a grid of landing points over the inside (a held
marker's half width in from its walls), kept to those the arm reaches at a height
that clears the rim and whatever lies under the held object, and of those the one
farthest from what is already there. What is there is what this run let go in it
(where the camera saw it land, else where it was let go, counted as high as it was
let go) and the markers the camera sees inside it now. Nothing here reads the
simulated world. Base frame, mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from py_trees.blackboard import Client
from py_trees.common import Access

from armtree.api.skill.reach import reachable
from armtree.config.workcell import Bin

#: Gap kept between the held object's bottom and the rim or what lies under it (mm).
CLEAR_MM = 4.0
#: Landing points per side of a bin's inside.
GRID = 9
#: Step of the release heights tried, from the place's height down (mm).
Z_STEP_MM = 2.0


@dataclass
class BinContents:
    """What a run has let go into each bin: marker key -> marker position (mm), per place."""

    dropped: dict[str, dict[Any, np.ndarray]] = field(default_factory=dict)

    def record(self, place: str, key: Any, position: np.ndarray) -> None:
        """Remember that the object ``key`` (a marker id, or any key) lies at ``position``."""
        self.dropped.setdefault(place, {})[key] = np.asarray(position, dtype=float).copy()

    def of(self, place: str) -> list[np.ndarray]:
        """The remembered positions in the bin at ``place``."""
        return list(self.dropped.get(place, {}).values())


#: Blackboard key of the run's :class:`BinContents`: what the skills that let go into bins
#: (``place``, ``release``, the clean-up's drops) have put there, for the next drop.
BINS_KEY = "/skills/bins"


def share_bins(bb: Client) -> None:
    """Let blackboard client ``bb`` read and write :data:`BINS_KEY`."""
    bb.register_key(key=BINS_KEY, access=Access.WRITE)
    bb.register_key(key=BINS_KEY, access=Access.READ)


def contents_of(bb: Client) -> BinContents:
    """The run's :class:`BinContents` on the blackboard (empty before the first drop)."""
    return bb.get(BINS_KEY) if bb.exists(BINS_KEY) else BinContents()


def remember_drop(bb: Client, place: str, key: Any, position: np.ndarray) -> None:
    """Write to the blackboard that object ``key`` lies at ``position`` (mm) in the bin at
    ``place``: a new :class:`BinContents`, so the run log has each change."""
    before = contents_of(bb)
    after = BinContents({name: dict(lying) for name, lying in before.dropped.items()})
    after.record(place, key, position)
    bb.set(BINS_KEY, after, overwrite=True)


def inside(spec: Bin, centre: np.ndarray, point: np.ndarray) -> bool:
    """True when ``point``'s x, y lie within the bin's inside (centred on ``centre``)."""
    half = 0.5 * np.asarray(spec.size_mm, dtype=float)
    return bool(np.all(np.abs(np.asarray(point)[:2] - np.asarray(centre)[:2]) <= half))


@dataclass(frozen=True)
class Drop:
    """A planned release: the tool's point (mm), where the held marker should land (x, y),
    and the distance to the nearest thing already in the bin (inf: empty)."""

    tool: np.ndarray
    landing: np.ndarray
    room_mm: float


def plan_drop(
    model: Any,
    place: np.ndarray,
    spec: Bin,
    contents: list[np.ndarray],
    hang_mm: float,
    marker_mm: float,
    offset_xy: np.ndarray | None = None,
) -> Drop | None:
    """The release into the bin at ``place`` (its x, y the inside's centre, its z the
    highest release) that lands farthest from ``contents`` (marker positions, mm).

    ``hang_mm``: how far the held object reaches below the tool centre; ``marker_mm``:
    the held marker's size (an object is at least that wide); ``offset_xy``: where the
    held marker sits beside the tool centre. Each landing point is let go from the
    highest reachable height at most the place's that keeps the object's bottom
    :data:`CLEAR_MM` above the rim and above every marker within a marker's diagonal
    of it (an object there lies partly under it). None when no such release is reachable.
    """
    place = np.asarray(place, dtype=float)
    offset = np.zeros(2) if offset_xy is None else np.asarray(offset_xy, dtype=float)[:2]
    half = np.maximum(0.5 * np.asarray(spec.size_mm, dtype=float) - 0.5 * marker_mm, 0.0)
    xs = place[0] + np.linspace(-half[0], half[0], GRID)
    ys = place[1] + np.linspace(-half[1], half[1], GRID)
    landings = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
    held = np.asarray(contents, dtype=float).reshape(-1, 3)
    under = marker_mm * math.sqrt(2.0)
    if len(held):
        gaps = np.linalg.norm(landings[:, None, :] - held[None, :, :2], axis=-1)
        room = gaps.min(axis=1)
        tops = np.where(gaps < under, held[None, :, 2], -np.inf).max(axis=1)
    else:
        room = np.full(len(landings), np.inf)
        tops = np.full(len(landings), -np.inf)
    lowest = np.maximum(tops, spec.rim_z_mm) + hang_mm + CLEAR_MM
    top = float(place[2])
    height = np.full(len(landings), np.nan)  # the highest reachable release of each landing
    for z in np.arange(top, float(lowest.min()) - 1e-9, -Z_STEP_MM):
        todo = np.isnan(height) & (lowest <= z + 1e-9)
        if not todo.any():
            continue
        tools = np.column_stack([landings[todo] - offset, np.full(int(todo.sum()), z)])
        height[np.flatnonzero(todo)[reachable(model, tools)]] = z
    ok = np.flatnonzero(~np.isnan(height))
    if not len(ok):
        return None
    # most room first; in an empty bin the landing farthest from the reachable ones'
    # middle (packing from one end leaves the most room for the next)
    spread = np.linalg.norm(landings[ok] - landings[ok].mean(axis=0), axis=1)
    best = ok[np.lexsort((-spread, -np.round(room[ok], 6)))[0]]
    tool = np.array([*(landings[best] - offset), height[best]])
    return Drop(tool, landings[best].copy(), float(room[best]))


__all__ = [
    "BINS_KEY",
    "CLEAR_MM",
    "BinContents",
    "Drop",
    "contents_of",
    "inside",
    "plan_drop",
    "remember_drop",
    "share_bins",
]
