"""Plain py_trees behaviours, unchanged: YAML parameters from the constructor's signature."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest

import armtree
from armtree.config.constructor_params import constructor_params, declared_params, yaml_type
from armtree.hooks import builtin_behaviours
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.schema import build_schema

# The form every py_trees user already has: no armtree import in the behaviour itself.
WAVE = '''
from __future__ import annotations

from typing import Literal

import py_trees
from py_trees.common import Status

import armtree


class Wave(py_trees.behaviour.Behaviour):
    """Wave a flag a number of times.

    Args:
        name: the behaviour's name
        mark: what is written on the flag
        times: how many waves
    """

    def __init__(self, name: str, mark: str, times: int = 1, speed: float = 1.0,
                 hand: Literal["left", "right"] = "left", colours: list[str] | None = None,
                 extra=None):
        super().__init__(name=name)
        self.mark, self.times, self.speed, self.hand = mark, times, speed, hand
        self.colours, self.extra = colours, extra
        self.waved = 0

    def update(self) -> Status:
        self.waved += 1
        self.feedback_message = f"waved {self.mark} {self.waved}/{self.times}"
        return Status.SUCCESS if self.waved >= self.times else Status.RUNNING


class Nameless(py_trees.behaviour.Behaviour):
    """A behaviour whose constructor names itself."""

    def __init__(self, level: int = 3):
        super().__init__(name="Nameless")
        self.level = level

    def update(self) -> Status:
        return Status.SUCCESS


@armtree.hookimpl
def armtree_behaviours():
    return {"wave": Wave, "nameless": Nameless}
'''


@pytest.fixture
def plugin(tmp_path: Path) -> Path:
    path = tmp_path / "waving.py"
    path.write_text(WAVE)
    return path


def manager() -> PluginManager:
    manager = PluginManager(autoload=False)
    manager.register(builtin_behaviours, "core_behaviours")
    return manager


def tree(tmp_path: Path, plugin: Path, root: str) -> Path:
    path = tmp_path / "t.yaml"
    body = textwrap.indent(textwrap.dedent(root).strip("\n"), "  ")
    path.write_text(f"plugins: [{plugin.name}]\nroot:\n{body}\n")
    return path


def errors(path: Path) -> list[str]:
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_tree(path, manager=manager())
    return [e.format() for e in info.value.errors]


def test_a_plain_behaviour_takes_its_constructor_parameters_from_yaml(tmp_path, plugin):
    path = tree(
        tmp_path,
        plugin,
        """
        wave: {name: Flag, mark: hello, times: 2, speed: 3, hand: right,
               colours: [red, white], extra: {any: [1, 2]}}
        """,
    )
    loaded = armtree.load_tree(path, manager=manager())
    wave = loaded.root
    assert type(wave).__name__ == "Wave" and wave.name == "Flag"
    assert (wave.mark, wave.times, wave.hand, wave.colours) == (
        "hello",
        2,
        "right",
        ["red", "white"],
    )
    assert wave.speed == 3.0 and isinstance(wave.speed, float)
    assert wave.extra == {"any": [1, 2]}
    result = armtree.run(loaded, record=False)
    assert result.status == "SUCCESS" and result.ticks == 2


def test_defaults_fill_what_the_tree_leaves_out(tmp_path, plugin):
    loaded = armtree.load_tree(tree(tmp_path, plugin, "wave: {mark: m}"), manager=manager())
    assert (loaded.root.times, loaded.root.hand, loaded.root.colours) == (1, "left", None)
    assert loaded.root.name == "wave"


def test_a_constructor_without_a_name_still_gets_the_node_name(tmp_path, plugin):
    loaded = armtree.load_tree(
        tree(tmp_path, plugin, "nameless: {name: Quiet, level: 5}"), manager=manager()
    )
    assert loaded.root.name == "Quiet" and loaded.root.level == 5


@pytest.mark.parametrize(
    ("root", "at", "message"),
    [
        ("wave: {mark: m, tims: 2}", "tims", "wave has no parameter 'tims'; did you mean 'times'?"),
        ("wave: {times: 2}", "wave", "wave needs parameter 'mark' (what is written on the flag)"),
        (
            "wave: {mark: m, times: two}",
            "two",
            "wave.times: expected an integer, got a string 'two'",
        ),
        ("wave: {mark: 7}", "7", "wave.mark: expected a string, got an integer 7"),
        ("wave: {mark: m, hand: up}", "up", "wave.hand: 'up' is not one of 'left', 'right'"),
        ("wave: {mark: m, colours: [1]}", "[1]", "wave.colours: expected a list of strings"),
    ],
)
def test_mistakes_are_reported_like_declared_parameters(tmp_path, plugin, root, at, message):
    path = tree(tmp_path, plugin, root)
    (error,) = errors(path)
    column = path.read_text().splitlines()[2].index(at) + 1
    assert error.startswith(f"{path}:3:{column}: {message}"), error


def test_listing_and_schema_show_the_constructor_parameters(plugin):
    registry = manager().extended([str(plugin)]).registry
    wave = registry.get("behaviour", "wave")
    shown = [p.describe() for p in wave.params]
    assert shown[0] == "mark: str  what is written on the flag"
    assert shown[1] == "times: int = 1  how many waves"
    schema = build_schema(registry)
    text = json.dumps(schema)
    assert '"wave"' in text and '"times"' in text and '"hand"' in text


@pytest.mark.parametrize(
    ("annotation", "expected"),
    [
        (int, ("int", ())),
        (float, ("float", ())),
        (bool, ("bool", ())),
        (str | None, ("str", ())),
        (list[float], ("vector", ())),
        (tuple[int, ...], ("vector", ())),
        (list[str], ("str_list", ())),
        (list, ("list", ())),
        (dict[str, int], ("dict", ())),
        (int | str, ("any", ())),
        (object, ("any", ())),
        ("Unresolved", ("any", ())),
    ],
)
def test_annotations_map_to_parameter_types(annotation, expected):
    assert yaml_type(annotation) == expected


def test_declared_params_win_over_the_signature():
    class Declared(armtree.Behaviour):
        PARAMS = (armtree.Param("x", "int", 1),)

    class Plain(armtree.Behaviour):
        def __init__(self, name: str, y: float = 2.0) -> None:
            super().__init__(name, y=y)

    assert [p.name for p in declared_params(Declared)] == ["x"]
    assert [(p.name, p.type, p.default) for p in declared_params(Plain)] == [("y", "float", 2.0)]
    assert constructor_params(builtin_behaviours.Timeout)[0].name == "duration"
