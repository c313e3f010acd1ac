"""Suction, gripper, falling, collisions, Duckybot cargo and scoring in the simulated world."""

from __future__ import annotations

import numpy as np
import pytest
from sim_fakes import run_world


def test_suction_picks_only_within_the_tolerance_and_carries_rigidly(make_world):
    world, emu = make_world()
    ducky = world.bodies["ducky"]
    emu.put([200, -100, ducky.top + 12])
    emu.suction = True
    run_world(world, emu, 0.2)
    assert world.held is None, "12 mm above the top face is too far for the cup"
    emu.suction = False
    run_world(world, emu, 0.1)
    emu.put([203, -98, ducky.top + 2])
    emu.suction = True
    run_world(world, emu, 0.1)
    assert world.held == "ducky"

    def in_tool():
        tool = emu.model.fk(emu.q)
        return np.linalg.inv(tool) @ ducky.pose

    held = in_tool()
    emu.put([120, 40, 150])
    run_world(world, emu, 0.1)
    assert np.allclose(in_tool(), held), "carried rigidly in the tool frame"
    assert world.score()["held"] == "ducky"


def test_released_trash_falls_into_the_bin_and_scores(make_world):
    world, emu = make_world()
    trash = world.bodies["trash"]
    emu.put([150, 150, trash.top])
    emu.suction = True
    run_world(world, emu, 0.1)
    emu.put([0, 250, 120])
    run_world(world, emu, 0.1)
    emu.suction = False
    run_world(world, emu, 0.05)
    assert trash.falling and trash.bottom > 3.0, "it takes time to fall"
    run_world(world, emu, 1.0)
    score = world.score()
    assert not trash.falling
    assert trash.bottom == pytest.approx(3.0)  # the bin's floor (wall 3 mm)
    assert score["in_bin"] == ["trash"] and score["trash_in_bin"] == 1
    assert score["objects"]["trash"]["in_bin"] == "bin"
    assert score["collision_count"] == 0


def test_ducky_dropped_on_the_parked_duckybot_leaves_with_it(make_world):
    world, emu = make_world()
    bot = world.duckybots["bot"]
    run_world(world, emu, 15.0)
    assert bot.parked, "the Duckybot waits at its loading spot"
    ducky = world.bodies["ducky"]
    emu.put([200, -100, ducky.top])
    emu.suction = True
    run_world(world, emu, 0.1)
    top = world.bodies["bot"].top
    here = world.bodies["bot"].pose[:2, 3]
    emu.put([here[0], here[1], top + ducky.size[2] + 5])
    run_world(world, emu, 0.1)
    emu.suction = False
    emu.put([here[0], here[1], 200])
    run_world(world, emu, 0.5)
    score = world.score()
    assert score["ducky_on_duckybot"] and score["duckies_on_duckybots"] == {"bot": ["ducky"]}
    assert ducky.bottom == pytest.approx(top)
    run_world(world, emu, 10.0)
    assert bot.phase in ("driving", "done") and bot.leg_index >= 1, "loaded: it leaves"
    assert world.bodies["bot"].pose[1, 3] > here[1] + 50
    assert np.allclose(ducky.pose[:2, 3], world.bodies["bot"].pose[:2, 3], atol=1.0)


def test_object_released_off_the_table_is_lost(make_world):
    world, emu = make_world(table={"x": [-300, 300], "y": [-400, 400]})
    ducky = world.bodies["ducky"]
    emu.put([200, -100, ducky.top])
    emu.suction = True
    run_world(world, emu, 0.1)
    emu.put([330, -100, 100])
    run_world(world, emu, 0.1)
    emu.suction = False
    run_world(world, emu, 1.5)
    assert world.score()["fell_off_table"] == ["ducky"]


def test_gripper_grasps_when_closing_around_an_object(make_world):
    world, emu = make_world()
    ducky = world.bodies["ducky"]
    emu.gripper = 60.0
    emu.put([200, -100, ducky.bottom + 15])
    run_world(world, emu, 0.1)
    assert world.held is None
    emu.gripper = 31.0
    run_world(world, emu, 0.1)
    assert world.held == "ducky"
    emu.put([200, -100, 100])
    run_world(world, emu, 0.1)
    assert ducky.bottom == pytest.approx(100 - 15)
    emu.gripper = 60.0
    run_world(world, emu, 1.0)
    assert world.held is None and ducky.bottom == pytest.approx(0.0, abs=1e-9)


def test_collision_is_recorded_once_and_halts_the_arm(make_world):
    world, emu = make_world()
    emu.put([200, 100, 60])
    emu.target = emu.model.ik(np.array([300, 100, 60.0]))
    run_world(world, emu, 2.0)
    score = world.score()
    assert score["collision_count"] == 1
    hit = score["collisions"][0]
    assert hit["other"] == "wall" and hit["depth_mm"] > 3
    assert emu.halted and "wall" in emu.halted[0]
    assert emu.model.position(emu.q)[0] < 260, "halted at the wall, not through it"


def test_collision_without_halting_when_configured(make_world):
    world, emu = make_world(physics={"halt_on_collision": False})
    emu.put([200, 100, 60])
    emu.target = emu.model.ik(np.array([300, 100, 60.0]))
    run_world(world, emu, 2.0)
    score = world.score()
    assert score["collision_count"] >= 1, "the tool, then the boom, pass through the wall"
    assert {c["other"] for c in score["collisions"]} == {"wall"}
    assert not emu.halted
    assert emu.model.position(emu.q)[0] == pytest.approx(300)


def test_a_body_moved_into_a_resting_arm_is_a_collision(make_world):
    world, emu = make_world(physics={"halt_on_collision": False})
    emu.put([200, 100, 60])
    run_world(world, emu, 0.5)
    assert world.score()["collision_count"] == 0
    world.bodies["wall"].pose[0, 3] = 200.0  # slid (in place) over the still tool
    run_world(world, emu, 0.1)
    assert {c["other"] for c in world.score()["collisions"]} == {"wall"}


def test_touching_a_top_face_is_not_a_collision(make_world):
    world, emu = make_world()
    ducky = world.bodies["ducky"]
    emu.put([200, -100, ducky.top + 30])
    emu.target = emu.model.ik(np.array([200, -100, ducky.top - 1.0]))
    run_world(world, emu, 1.0)
    assert world.score()["collision_count"] == 0


def test_configured_faults_are_passed_to_the_emulator(make_world):
    world, emu = make_world(faults={"missed_steps": {"joint": 1, "amount": 8}})
    assert emu.injected == [("missed_steps", {"joint": 1.0, "amount": 8.0})]


def script(world, emu):
    """A scripted pick-and-place used to compare runs."""
    ducky = world.bodies["ducky"]
    emu.target = emu.model.ik(np.array([200, -100, ducky.top]))
    run_world(world, emu, 3.0)
    emu.suction = True
    emu.target = emu.model.ik(np.array([50, 200, 120]))
    run_world(world, emu, 4.0)
    emu.suction = False
    run_world(world, emu, 3.0)


def test_same_seed_same_world_state(make_world):
    a, ea = make_world()
    b, eb = make_world()
    script(a, ea)
    script(b, eb)
    assert a.state() == b.state()
    assert a.score() == b.score()
    assert a.duckybots["bot"].trail == b.duckybots["bot"].trail


def test_missed_steps_under_load_at_the_configured_rate(make_world):
    faults = {"missed_steps": {"rate_per_s": 4.0, "max_amount": 1.5, "joints": [1, 2]}}
    world, emu = make_world(faults=faults)
    run_world(world, emu, 5.0)
    assert emu.injected == [], "an idle arm does not slip"
    emu.target = emu.model.ik(np.array([150.0, 150.0, 100.0]))
    emu.speed = 20.0
    run_world(world, emu, 5.0)
    slips = [opts for fault, opts in emu.injected if fault == "missed_steps"]
    assert 8 <= len(slips) <= 35
    assert all(o["joint"] in (1, 2) and abs(o["amount"]) <= 1.5 for o in slips)
    assert len(world.score()["missed_steps"]) == len(slips)
    events = [e for e in world.events if e.kind == "missed_steps"]
    units = {e.detail["unit"] for e in events}
    assert units == {world.model.joints[e.detail["joint"]].unit for e in events} and units
    from armtree.plugins.sim.plugin import _NOTABLE

    shown = _NOTABLE["missed_steps"](events[0].detail)  # what the live view and summary show
    assert shown.endswith(f" {events[0].detail['unit']}") and "slipped by" in shown
    again, emu2 = make_world(faults=faults)
    run_world(again, emu2, 5.0)
    emu2.target = emu2.model.ik(np.array([150.0, 150.0, 100.0]))
    emu2.speed = 20.0
    run_world(again, emu2, 5.0)
    assert emu2.injected == emu.injected, "the same slips for the same seed"


def test_bad_missed_steps_options(make_world):
    from armtree.errors import ConfigError

    with pytest.raises(ConfigError, match="world.faults.missed_steps.joints"):
        make_world(faults={"missed_steps": {"rate_per_s": 1.0, "joints": ["x"]}})
