"""Parameter declarations: kinds, valid ranges and item counts, checked at load time."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

import armtree
from armtree.config.params import KINDS, Param, check_value
from armtree.errors import shown
from armtree.hooks.plugin_manager import get_plugin_manager


def test_kind_must_be_a_known_one() -> None:
    assert {"place", "tag_role", "position"} <= set(KINDS)
    with pytest.raises(ValueError, match="kind must be one of"):
        Param("x", "str", kind="colour")


@pytest.mark.parametrize(
    ("value", "accepted"),
    [(0, False), (1e-300, True), (5, True), (1000, True), (1000.5, False), (-1, False)],
)
def test_exclusive_minimum_and_maximum(value: float, accepted: bool) -> None:
    rate = Param("rate", "float", 1.0, "Hz", exclusive_minimum=0.0, maximum=1000.0)
    if accepted:
        assert check_value(rate, value) == pytest.approx(value, rel=0, abs=0)
    else:
        with pytest.raises(ValueError, match=r"expected a number > 0 and <= 1000 Hz"):
            check_value(rate, value)


def test_vector_bounds_each_item_and_its_length() -> None:
    span = Param("span", "vector", [0, 1], "deg", minimum=-360.0, maximum=360.0, length=2)
    assert check_value(span, [-10, 10]) == [-10.0, 10.0]
    with pytest.raises(ValueError, match="expected 2 items, got 3"):
        check_value(span, [1, 2, 3])
    with pytest.raises(ValueError, match=r">= -360 and <= 360 deg, got -1e\+300"):
        check_value(span, [-1e300, 1e300])


def test_max_items_bounds_a_list() -> None:
    poses = Param("poses", "list", [], max_items=3)
    assert check_value(poses, [1, 2, 3]) == [1, 2, 3]
    with pytest.raises(ValueError, match="at most 3 items, got 4"):
        check_value(poses, [1, 2, 3, 4])


@pytest.mark.parametrize("digits", [400, 4300, 5000])
def test_huge_integers_are_a_value_error_with_a_short_message(digits: int) -> None:
    huge = 10**digits - 1
    with pytest.raises(ValueError) as info:
        check_value(Param("hz", "float"), huge)
    assert len(str(info.value)) < 120
    assert "digits" in str(info.value)


def test_shown_is_bounded_for_huge_and_nested_values() -> None:
    deep: list = []
    node = deep
    for _ in range(5000):
        node.append([])
        node = node[0]
    assert len(shown(deep)) < 100
    assert len(shown(list(range(10**6)))) < 100
    assert "digits" in shown(10**5000)


def test_ranges_reach_the_schema_and_the_listing() -> None:
    step = Param("step_deg", "float", 5.0, "deg", minimum=0.1, maximum=360.0)
    schema = step.json_schema()["anyOf"][0]
    assert (schema["minimum"], schema["maximum"]) == (0.1, 360.0)
    assert "(>= 0.1 and <= 360)" in step.describe()


def test_the_shipped_skills_declare_places_and_tag_roles() -> None:
    registry = get_plugin_manager().registry
    kinds = {
        (name, p.name): p.kind
        for name in registry.names("behaviour")
        for p in getattr(registry.get("behaviour", name).factory, "PARAMS", ())
    }
    assert kinds[("pick", "from")] == "place"
    assert kinds[("pick", "tag")] == "tag_role"
    assert kinds[("place", "at")] == "place"
    assert kinds[("search", "tag")] == "tag_role"
    assert kinds[("search", "bin")] == "place"
    assert kinds[("move_to", "to")] == "place"


@pytest.mark.parametrize(
    ("option", "message"),
    [
        # the sweep's step and range are the profile's (workcell.survey; test_profile_workcell)
        ("sweeps: 1000000000", "search.sweeps: expected a number >= 1 and <= 100"),
    ],
)
def test_unbounded_search_values_fail_at_load_with_their_position(
    tmp_path: Path, option: str, message: str
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        textwrap.dedent(
            f"""\
            rig: sim_dobot
            root:
              search:
                tag: duckybot
                {option}
            """
        )
    )
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_tree(tree)
    error = info.value
    assert len(error.errors) == 1
    assert (error.file, error.line, error.column) == (
        str(tree),
        5,
        5 + len(option.split(":")[0]) + 2,
    )
    assert message in error.message
