"""What the suction cup holds against what lies under the tool: collisions and landing.

The tool centre is the end effector's lowest point, so bodies whose top is below it
are never hit by the arm's own boxes; what it holds hangs lower and must still be.
"""

from __future__ import annotations

import pytest
from sim_fakes import run_world


def carry_ducky_over_the_parked_bot(make_world, sink_mm: float):
    """Park the Duckybot, pick the ducky, lower it ``sink_mm`` into the bot's top."""
    world, emu = make_world()
    run_world(world, emu, 15.0)
    assert world.duckybots["bot"].parked
    ducky = world.bodies["ducky"]
    emu.put([200, -100, ducky.top])
    emu.suction = True
    run_world(world, emu, 0.1)
    assert world.held == "ducky"
    bot = world.bodies["bot"]
    x, y = bot.pose[:2, 3]
    emu.put([x, y, bot.top + ducky.size[2] + 20])
    run_world(world, emu, 0.1)
    emu.put([x, y, bot.top + ducky.size[2] - sink_mm])
    run_world(world, emu, 0.1)
    return world, emu, ducky, bot


def test_held_object_pressed_into_a_body_below_the_tool_is_a_collision(make_world):
    world, emu, _, _ = carry_ducky_over_the_parked_bot(make_world, sink_mm=6.0)
    score = world.score()
    assert score["collision_count"] == 1, score["collisions"]
    hit = score["collisions"][0]
    assert (hit["link"], hit["other"]) == ("held ducky", "bot") and hit["depth_mm"] > 3
    assert emu.halted and "held ducky hit bot" in emu.halted[0]


def test_held_object_above_a_body_is_no_collision(make_world):
    world, _, _, _ = carry_ducky_over_the_parked_bot(make_world, sink_mm=-5.0)
    assert world.score()["collision_count"] == 0


@pytest.mark.parametrize("sink_mm", [-5.0, 0.0, 2.0])
def test_released_on_or_shallowly_inside_a_body_rests_on_it(sink_mm, make_world):
    world, emu, ducky, bot = carry_ducky_over_the_parked_bot(make_world, sink_mm=sink_mm)
    emu.suction = False
    run_world(world, emu, 0.5)
    score = world.score()
    assert score["collision_count"] == 0, "within the collision tolerance: a touch"
    assert score["objects"]["ducky"]["on"] == "bot" and score["ducky_on_duckybot"]
    assert ducky.bottom == pytest.approx(bot.top)
