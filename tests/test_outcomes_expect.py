"""Declared outcomes: reading ``expect:``, checking names at load time, judging, verdicts."""

from __future__ import annotations

import textwrap

import pytest

from armtree import ConfigError, load_profile, load_tree
from armtree.api.outcomes.expect import judge, parse_expectations, verdict
from armtree.api.outcomes.failures import FailureLog, chain_text, reason_key
from armtree.api.outcomes.predicates import BUILTIN_PREDICATES
from armtree.api.outcomes.truth import WorldObject, WorldTruth
from armtree.config.yamlio import load_yaml
from armtree.hooks.plugin_manager import make_plugin_manager
from armtree.loader.tree_keys import world_inventory


def world(**changes) -> WorldTruth:
    """A small world: a ducky on a Duckybot, two trash (one in the bin), a bin."""
    objects = {
        "ducky": WorldObject("ducky", "ducky", "ducky", (160.0, 92.0, -25.0), on="duckybot"),
        "duckybot": WorldObject("duckybot", "duckybot", "duckybot", (160.0, 92.5, -35.0)),
        "trash_a": WorldObject(
            "trash_a", "trash", "trash", (0.0, 185.0, -32.0), on="bin", inside="bin"
        ),
        "trash_b": WorldObject("trash_b", "trash", "trash", (183.0, 26.0, -35.0)),
        "bin": WorldObject("bin", "bin", None, (0.0, 185.0, -35.0), container=True),
    }
    truth = WorldTruth(
        objects=objects,
        roles={"ducky": ["ducky"], "duckybot": ["duckybot"], "trash": ["trash_a", "trash_b"]},
        places={"home": (185.0, 0.0, 30.0), "drop": (0.0, 190.0, 30.0)},
    )
    for key, value in changes.items():
        setattr(truth, key, value)
    return truth


def parse(text: str, truth: WorldTruth | None = None):
    data = load_yaml(textwrap.dedent(text), "t.yaml")
    return parse_expectations(
        data["expect"], data.value_mark("expect"), "t.yaml", truth or world(), BUILTIN_PREDICATES
    )


def test_entries_name_one_predicate_and_read_as_claims():
    expect, errors = parse(
        """\
        expect:
          - {object: ducky, on: duckybot}
          - {objects: trash, in: bin}
          - {object: ducky, at: home, within_mm: 200}
          - {object: trash_b, held: false}
          - {held: nothing}
          - {collisions: 0}
          - {missed_steps: 2}
        """
    )
    assert errors == []
    assert [e.text() for e in expect] == [
        "ducky on duckybot",
        "every trash in bin",
        "ducky at home within 200 mm",
        "trash_b not held",
        "held: nothing",
        "collisions <= 0",
        "missed steps <= 2",
    ]
    assert expect[0].predicate == "on", "a bare YAML 1.1 `on` key reads as the predicate on"
    assert expect[1].every and not expect[0].every


@pytest.mark.parametrize(
    ("entry", "at", "message"),
    [
        (
            "{object: duky, on: duckybot}",
            "duky",
            "no body or tag role 'duky' in this world; did you mean 'ducky'?",
        ),
        ("{object: ducky, on: duckybto}", "duckybto", "no body or tag role 'duckybto'"),
        ("{object: ducky, in: trash_b}", "trash_b", "'trash_b' is not a container"),
        ("{object: ducky, at: hom}", "hom", "did you mean 'home'?"),
        ("{object: ducky, at: home, within_mm: 0}", "0", "tolerance in mm > 0"),
        ("{object: ducky}", "{", "names no predicate"),
        ("{object: ducky, on: bin, in: bin}", "{", "names 2 predicates"),
        ("{object: ducky, objects: trash, in: bin}", "objects", "not both"),
        ("{on: bin}", "{", "say what it is about"),
        ("{object: ducky, collisions: 0}", "object", "takes no object"),
        ("{collisions: -1}", "-1", "integer >= 0"),
        ("{object: ducky, in: bin, tolerance: 3}", "tolerance", "has no option 'tolerance'"),
        ("{object: ducky, held: maybe}", "maybe", "true or false"),
        ("{held: dukcy}", "dukcy", "or write held: nothing"),
        ("just text", "just", "an expectation is a mapping"),
    ],
)
def test_bad_entries_are_errors_at_their_line_and_column(entry, at, message):
    line = f"  - {entry}"
    expect, errors = parse(f"expect:\n{line}\n")
    assert expect == []
    assert len(errors) == 1, [e.format() for e in errors]
    error = errors[0]
    assert (error.file, error.line, error.column) == ("t.yaml", 2, line.index(at) + 1)
    assert message in error.message


def test_expect_must_be_a_list():
    _, errors = parse("expect: {collisions: 0}\n")
    assert "expected a list of expectations" in errors[0].message


def test_one_of_a_role_or_every_one_of_it():
    truth = world()
    expect, _ = parse(
        """\
        expect:
          - {object: trash, in: bin}
          - {objects: trash, in: bin}
          - {objects: [ducky, trash_a], held: false}
        """
    )
    some, every, named = judge(expect, truth, BUILTIN_PREDICATES)
    assert (some.status, some.measured, some.detail) == ("pass", "bin", "trash_a in bin")
    assert every.status == "fail"
    assert every.measured == {"trash_a": "bin", "trash_b": None}
    assert every.detail == "1 of 2: trash_b on table"
    assert named.status == "pass"


def test_every_one_of_none_holds_and_one_of_none_does_not():
    truth = world(roles={"trash": []})
    expect, _ = parse(
        "expect:\n  - {objects: trash, in: bin}\n  - {object: trash, in: bin}\n", truth
    )
    every, some = judge(expect, truth, BUILTIN_PREDICATES)
    assert (every.status, some.status) == ("pass", "fail")


def test_on_follows_a_stack_down_and_reports_what_it_rests_on():
    truth = world()
    truth.objects["trash_b"] = WorldObject("trash_b", "trash", "trash", (160, 92, 0), on="ducky")
    expect, _ = parse(
        "expect:\n  - {object: trash_b, on: duckybot}\n  - {object: trash_b, on: bin}\n"
    )
    on_bot, on_bin = judge(expect, truth, BUILTIN_PREDICATES)
    assert (on_bot.status, on_bot.measured) == ("pass", "ducky")
    assert (on_bin.status, on_bin.detail) == ("fail", "trash_b on ducky")


def test_at_measures_the_distance_in_the_table_plane():
    expect, _ = parse(
        "expect:\n  - {object: trash_a, at: drop, within_mm: 5.5}\n  - {object: trash_a, at: drop}\n"
    )
    within, default = judge(expect, world(), BUILTIN_PREDICATES)
    assert within.status == "pass" and within.measured == pytest.approx(5.0)
    assert default.status == "pass", "the default tolerance is 15 mm"
    expect, _ = parse("expect:\n  - {object: trash_b, at: drop, within_mm: 100}\n")
    (far,) = judge(expect, world(), BUILTIN_PREDICATES)
    assert far.status == "fail" and far.measured == pytest.approx(245.7, abs=0.1)


def test_at_a_bin_means_inside_it_wherever_in_it():
    truth = world()
    inside = WorldObject("trash_a", "trash", "trash", (40.0, 225.0, -32.0), on="bin", inside="bin")
    on_bin = WorldObject("trash_b", "trash", "trash", (0.0, 190.0, 5.0), on="bin")
    truth.objects.update(trash_a=inside, trash_b=on_bin)  # 57 mm off centre; 5 mm, on top
    expect, _ = parse(
        "expect:\n  - {object: trash_a, at: bin, within_mm: 10}\n"
        "  - {object: trash_b, at: bin, within_mm: 10}\n",
        truth,
    )
    inside, on_top = judge(expect, truth, BUILTIN_PREDICATES)
    assert (inside.status, inside.measured, inside.detail) == ("pass", "bin", "trash_a in bin")
    assert (on_top.status, on_top.detail) == ("fail", "trash_b on bin")


def test_held_and_event_counts():
    truth = world(
        held="trash_b",
        collisions=[{"time": 3.2, "link": "tool", "other": "trash_a", "depth_mm": 6.2}],
        missed_steps=[{"time": 1.0, "joint": 1, "amount": 0.5}] * 4,
    )
    truth.objects["trash_b"] = WorldObject(
        "trash_b", "trash", "trash", (0, 0, 10), on=None, held=True
    )
    expect, _ = parse(
        """\
        expect:
          - {held: nothing}
          - {held: trash}
          - {object: trash_b, held: true}
          - {collisions: 0}
          - {collisions: 1}
          - {missed_steps: 3}
        """
    )
    results = judge(expect, truth, BUILTIN_PREDICATES)
    assert [r.status for r in results] == ["fail", "pass", "pass", "fail", "pass", "fail"]
    assert results[0].measured == "trash_b"
    assert results[3].detail == "1 collision: tool hit trash_a 6.2 mm at t=3.20 s"
    assert results[5].measured == 4 and results[5].detail.endswith("and 1 more")


def test_without_ground_truth_nothing_is_checked_and_the_tree_decides():
    expect, _ = parse("expect:\n  - {object: ducky, on: duckybot}\n")
    (result,) = judge(expect, None, BUILTIN_PREDICATES)
    assert (result.status, result.detail) == ("not checked", "no ground truth on this rig")
    assert verdict("SUCCESS", [result]) == "success"
    assert verdict("FAILURE", [result]) == "failure"


def test_verdicts():
    expect, _ = parse("expect:\n  - {object: ducky, on: duckybot}\n  - {object: ducky, on: bin}\n")
    holds, fails = judge(expect, world(), BUILTIN_PREDICATES)
    assert verdict("SUCCESS", [holds]) == "success"
    assert verdict("SUCCESS", [holds, fails]) == "false success"
    assert verdict("FAILURE", [holds]) == "false failure"
    assert verdict("FAILURE", [holds, fails]) == "failure"
    assert verdict("FAILURE", []) == "failure"
    assert verdict("INTERRUPTED", [fails]) == "interrupted"


def test_a_predicate_that_raises_is_not_checked_and_says_why():
    class Broken(BUILTIN_PREDICATES["on"].__class__):
        def judge(self, entry, obj, world):
            raise RuntimeError("boom")

    expect, _ = parse("expect:\n  - {object: ducky, on: duckybot}\n")
    (result,) = judge(expect, world(), {**BUILTIN_PREDICATES, "on": Broken()})
    assert result.status == "not checked" and "RuntimeError: boom" in result.detail


def test_failure_chain_from_the_root_and_what_a_retry_absorbed():
    log = FailureLog()
    log.add(5, 0.25, "Root/Retry/Pick", "no ducky seen near 3 spots")
    log.add(9, 0.45, "Root/Either/Look", "nothing in view")  # the selector went on
    log.add(12, 0.6, "Root/Retry/Pick", "gripper empty after 2.0 s")
    log.add(12, 0.6, "Root/Retry", "final failure")
    log.add(12, 0.6, "Root", "")
    chain = log.chain("Root")
    assert [f.path for f in chain] == ["Root", "Root/Retry", "Root/Retry/Pick"]
    assert chain_text(chain) == "Root > Retry (final failure) > Pick: gripper empty after 2.0 s"
    absorbed = log.absorbed("Root")
    assert [chain_text(c) for c in absorbed] == [
        "Pick: no ducky seen near 3 spots",
        "Look: nothing in view",
    ]
    assert (
        reason_key(chain_text(chain))
        == "Root > Retry (final failure) > Pick: gripper empty after N s"
    )


def test_a_root_that_never_failed_has_no_chain():
    log = FailureLog()
    log.add(3, 0.1, "Root/Guard", "low battery")
    assert log.chain("Root") == []
    assert [c[0].path for c in log.absorbed("Root")] == ["Root/Guard"]


# -- through the loader ---------------------------------------------------------------


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_the_loader_checks_names_against_the_profiles_world(tmp_path):
    path = write(
        tmp_path,
        "t.yaml",
        """\
        rig: sim_dobot
        params:
          thing: {default: ducky}
        expect:
          - {object: "{thing}", "on": duckybot}
          - {objects: trash, in: garbage_bin}
          - {object: ducky, at: ducky_pickup, within_mm: 20}
        root: {success: {}}
        """,
    )
    tree = load_tree(path)
    assert [e.text() for e in tree.expect] == [
        "ducky on duckybot",
        "every trash in garbage_bin",
        "ducky at ducky_pickup within 20 mm",
    ]
    with pytest.raises(ConfigError) as info:
        load_tree(path, overrides=["thing=duckie"])
    assert info.value.errors[0].location() == f"{path}:5:14"
    assert "no body or tag role 'duckie' in this world; did you mean 'ducky'?" in str(info.value)


def test_an_unknown_place_lists_each_choice_once(tmp_path):
    path = write(
        tmp_path,
        "t.yaml",
        """\
        rig: sim_dobot
        expect: [{object: ducky, at: nowhere}]
        root: {success: {}}
        """,
    )
    with pytest.raises(ConfigError) as info:
        load_tree(path)
    assert info.value.errors[0].location() == f"{path}:2:30"
    choices = str(info.value).split("choose one of: ", 1)[1].split(", ")
    assert "garbage_bin" in choices and len(choices) == len(set(choices))


def test_on_a_rig_without_ground_truth_names_come_from_tags_and_places(tmp_path):
    profile_path = write(
        tmp_path,
        "bench.yaml",
        """\
        arm: {type: dobot_v1, port: /dev/ttyUSB7}
        tags: {ducky: {id: 0, size_mm: 25}, duckybot: {id: 1, size_mm: 25}}
        places: {garbage_bin: [0, 185, 30]}
        """,
    )
    profile = load_profile(profile_path)
    truth = world_inventory(profile, make_plugin_manager())
    assert not truth.complete and truth.knows("ducky") and "garbage_bin" in truth.places
    data = load_yaml(
        "expect:\n  - {object: ducky, in: garbage_bin}\n  - {object: duck, on: duckybot}\n",
        "t.yaml",
    )
    expect, errors = parse_expectations(data["expect"], None, "t.yaml", truth, BUILTIN_PREDICATES)
    assert [e.text() for e in expect] == ["ducky in garbage_bin"]
    assert len(errors) == 1 and "'duck'" in errors[0].message


PLUGIN = '''
import armtree
from armtree.api.outcomes.predicates import Judgement, Predicate


class Upright(Predicate):
    """upright: the body's yaw is within 10 degrees of zero (a stand-in)."""

    VALUE = {"type": "boolean"}

    def check(self, entry, world):
        return [] if isinstance(entry.value, bool) else [("upright", "true or false")]

    def judge(self, entry, obj, world):
        ok = abs(obj.yaw_deg) <= 10
        return Judgement(ok == entry.value, obj.yaw_deg, f"{obj.name} yaw {obj.yaw_deg:.0f}")


@armtree.hookimpl
def armtree_predicates():
    return {NAME: Upright}
'''


def test_a_plugin_adds_a_predicate_and_may_not_take_a_builtin_name(tmp_path):
    write(tmp_path, "upright.py", PLUGIN.replace("NAME", '"upright"'))
    path = write(
        tmp_path,
        "t.yaml",
        """\
        rig: sim_dobot
        plugins: [upright.py]
        expect:
          - {object: ducky, upright: true}
        root: {success: {}}
        """,
    )
    manager = make_plugin_manager()
    tree = load_tree(path, manager=manager)
    assert [e.predicate for e in tree.expect] == ["upright"]
    write(tmp_path, "clash.py", PLUGIN.replace("NAME", '"on"'))
    clash = write(
        tmp_path,
        "c.yaml",
        """\
        rig: sim_dobot
        plugins: [clash.py]
        expect:
          - {held: nothing}
        root: {success: {}}
        """,
    )
    with pytest.raises(
        ConfigError, match="predicate 'on' of plugin 'clash' clashes with armtree's own"
    ):
        load_tree(clash, manager=make_plugin_manager())
