"""The ``expect:`` predicates ``parked`` and ``tool_within_mm``, judged on what the sim's world hands them."""

from __future__ import annotations

import numpy as np
import pytest
from sim_fakes import run_world

from armtree import ConfigError, load_tree
from armtree.api.outcomes.expect import judge
from armtree.api.outcomes.predicates import BUILTIN_PREDICATES
from armtree.api.outcomes.truth import WorldObject, WorldTruth
from armtree.hooks.plugin_manager import PluginManager
from armtree.plugins.sim.truth import world_truth

PREDICATES = BUILTIN_PREDICATES


def truth(phase: str = "parked", tool=(160.0, 92.0, 15.0)) -> WorldTruth:
    """A Duckybot with its marker top at z = -5 and a tool at ``tool``."""
    objects = {
        "duckybot": WorldObject("duckybot", "duckybot", "duckybot", (160.0, 92.0, -35.0)),
        "ducky": WorldObject("ducky", "ducky", "ducky", (0.0, -150.0, -35.0), held=True, on=None),
    }
    return WorldTruth(
        objects=objects,
        roles={"duckybot": ["duckybot"], "ducky": ["ducky"]},
        extra={
            "duckybots": {"duckybot": {"phase": phase, "pose": (160.0, 92.0, 30.0)}},
            "markers": {"duckybot": (160.0, 92.0, -5.0), "ducky": (0.0, -150.0, -10.0)},
            "tool_mm": tool,
        },
    )


def entry(tmp_path, line: str):
    """The one expectation of a tiny tree on sim_dobot, parsed and checked by the loader."""
    path = tmp_path / "t.yaml"
    path.write_text(f"rig: sim_dobot\nexpect:\n  - {line}\nroot: {{success: {{}}}}\n")
    return load_tree(path).expect[0]


def outcome(exp, world):
    (result,) = judge([exp], world, PREDICATES)
    return result


def test_parked_holds_for_a_waiting_duckybot_and_fails_for_a_driving_one(tmp_path):
    exp = entry(tmp_path, "{object: duckybot, parked: true}")
    ok = outcome(exp, truth("parked"))
    assert ok.status == "pass" and ok.measured == "parked"
    moving = outcome(exp, truth("driving"))
    assert moving.status == "fail" and "duckybot driving at [160, 92] mm" in moving.detail
    assert (
        outcome(entry(tmp_path, "{object: duckybot, parked: false}"), truth("driving")).status
        == "pass"
    )
    # a body that is no Duckybot is parked when it is at rest: a held ducky is not
    held = outcome(entry(tmp_path, "{object: ducky, parked: true}"), truth())
    assert held.status == "fail" and held.measured == "held"


def test_tool_within_measures_from_the_point_above_the_marker(tmp_path):
    exp = entry(tmp_path, "{object: duckybot, tool_within_mm: 5, above_mm: 20}")
    assert exp.text(PREDICATES) == "duckybot tool within 5 mm of 20 mm above its marker"
    near = outcome(exp, truth(tool=(161.0, 92.0, 16.0)))
    assert near.status == "pass" and near.measured == pytest.approx(np.sqrt(2.0), abs=0.01)
    far = outcome(exp, truth(tool=(168.0, 92.0, 15.0)))
    assert far.status == "fail" and far.measured == pytest.approx(8.0, abs=0.01)
    assert "the tool 8.0 mm from [160, 92, 15] mm" in far.detail
    # the default height is the marker itself
    touch = entry(tmp_path, "{object: duckybot, tool_within_mm: 5}")
    assert outcome(touch, truth(tool=(160.0, 92.0, -3.0))).status == "pass"


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("{object: duckybot, parked: 3}", "expected true or false, got 3"),
        ("{object: duckybot, tool_within_mm: -1}", "expected a distance in mm > 0, got -1"),
        ("{object: duckybot, tool_within_mm: 5, above_mm: high}", "expected a height in mm"),
        ("{object: duckbot, parked: true}", "did you mean 'duckybot'"),
    ],
)
def test_bad_entries_are_errors_at_their_line(tmp_path, line, message):
    with pytest.raises(ConfigError) as info:
        entry(tmp_path, line)
    assert message in str(info.value)
    assert info.value.errors[0].line == 3


def test_the_world_reports_its_duckybots_tool_and_markers(make_world):
    world, emu = make_world()
    start = world_truth(world, {})
    assert start.extra["duckybots"]["bot"]["phase"] == "driving"
    np.testing.assert_allclose(start.extra["tool_mm"], [200.0, 0.0, 200.0], atol=1e-6)
    top = world.bodies["ducky"].top_pose()[:3, 3]
    np.testing.assert_allclose(start.extra["markers"]["ducky"], top, atol=1e-9)
    run_world(world, emu, 15.0)
    assert world_truth(world, {}).extra["duckybots"]["bot"]["phase"] == "parked"


def test_they_are_armtree_s_own_so_trees_declaring_them_load_without_the_sim():
    # a hardware profile with the sim plugin blocked: nothing judges them, but the tree loads
    manager = PluginManager(blocked=("sim",), autoload=True)
    manager.load_entry_points()
    assert not manager.pm.has_plugin("sim")
    for name in ("track.yaml", "touch_tag.yaml"):
        tree = load_tree(name, rig="dobot_v1.yaml", overrides=["tag=duckybot"], manager=manager)
        assert {e.predicate for e in tree.expect} & {"parked", "tool_within_mm"}


def test_track_and_touch_tag_declare_them():
    track = load_tree("track.yaml")
    assert "duckybot parked" in [e.text(PREDICATES) for e in track.expect]
    touch = load_tree("touch_tag.yaml")
    assert any(e.predicate == "tool_within_mm" for e in touch.expect)
