"""Letting go into a bin: drops spread across its inside, high enough for what is in it."""

from __future__ import annotations

import math

import numpy as np
from test_skills_fakes import CylModel

from armtree.api.skill.reach import reachable
from armtree.config.workcell import Bin
from armtree.plugins.skills.bins import CLEAR_MM, plan_drop

BIN = Bin((74.0, 74.0), -15.0)
PLACE = np.array([0.0, 185.0, 30.0])
MARKER = 25.0
HANG = 25.0  # a 25 mm tall object held at its top


class ShortReach(CylModel):
    """The cylindrical fake, reaching only 190 mm from the base axis (a Dobot's far limit)."""

    def ik_all(self, target: np.ndarray) -> np.ndarray:
        sols = super().ik_all(target)
        far = np.hypot(target[..., 0], target[..., 1]) > 190.0
        sols[far] = np.nan
        return sols


def fill(model, count: int) -> list[np.ndarray]:
    """Drop ``count`` objects one after the other, each seen where it landed (top at -7)."""
    contents: list[np.ndarray] = []
    for _ in range(count):
        drop = plan_drop(model, PLACE, BIN, contents, HANG, MARKER)
        assert drop is not None
        contents.append(np.array([*drop.landing, -7.0]))
    return contents


def test_successive_drops_spread_across_the_inside_instead_of_stacking():
    contents = fill(CylModel(), 4)
    xy = np.array([c[:2] for c in contents])
    gaps = [np.linalg.norm(a - b) for i, a in enumerate(xy) for b in xy[i + 1 :]]
    # four 25 mm markers fit a 74 mm inside without one landing on another
    assert min(gaps) >= MARKER * math.sqrt(2.0)
    # every marker lands wholly inside the bin
    assert np.all(np.abs(xy - PLACE[:2]) <= 0.5 * 74.0 - 0.5 * MARKER + 1e-9)


def test_a_drop_over_what_is_in_the_bin_is_let_go_high_enough_to_clear_it():
    contents = fill(CylModel(), 4)
    drop = plan_drop(CylModel(), PLACE, BIN, contents, HANG, MARKER)
    assert drop is not None and drop.room_mm < MARKER * math.sqrt(2.0)
    assert drop.tool[2] - HANG >= -7.0 + CLEAR_MM - 1e-9  # the held bottom clears the tops
    assert drop.tool[2] <= PLACE[2]


def test_only_reachable_releases_are_chosen_and_a_full_reachable_part_is_refused():
    model = ShortReach()
    drops = []
    contents: list[np.ndarray] = []
    for _ in range(2):
        drop = plan_drop(model, PLACE, BIN, contents, HANG, MARKER)
        assert drop is not None and reachable(model, drop.tool)
        drops.append(drop)
        contents.append(np.array([*drop.landing, -7.0]))
    assert np.linalg.norm(drops[0].landing - drops[1].landing) >= MARKER * math.sqrt(2.0)
    # what is in the bin reaches so high that no release at most the place's height clears it
    tall = [np.array([x, y, 10.0]) for x in (-25, 0, 25) for y in (160, 185, 210)]
    assert plan_drop(model, PLACE, BIN, tall, HANG, MARKER) is None


def test_the_tool_is_moved_so_the_held_marker_lands_where_planned():
    offset = np.array([6.0, -4.0])
    drop = plan_drop(CylModel(), PLACE, BIN, [], HANG, MARKER, offset)
    assert drop is not None
    np.testing.assert_allclose(drop.tool[:2] + offset, drop.landing, atol=1e-9)
