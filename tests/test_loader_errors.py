"""Tree loader errors: each class at its exact line and column, and all of a file at once."""

from __future__ import annotations

import textwrap
from pathlib import Path

import py_trees
import pytest

import armtree
from armtree.hooks import builtin_behaviours
from armtree.hooks.plugin_manager import PluginManager


def core_manager(*plugins: object) -> PluginManager:
    """A manager holding only the built-in behaviours (and ``plugins``), no entry points."""
    manager = PluginManager(autoload=False)
    manager.register(builtin_behaviours, "core_behaviours")
    for i, plugin in enumerate(plugins):
        manager.register(plugin, f"test_plugin_{i}")
    return manager


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return path


def errors_of(path: Path, **kwargs) -> list[armtree.ConfigError]:
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_tree(path, manager=core_manager(), **kwargs)
    return info.value.errors


def one_error(path: Path, **kwargs) -> armtree.ConfigError:
    errors = errors_of(path, **kwargs)
    assert len(errors) == 1, [e.format() for e in errors]
    return errors[0]


CASES = [
    (
        "unknown node type",
        """
        root:
          sequence:
            - success: {}
            - sucess: {}
        """,
        (4, 7),
        "unknown node type 'sucess'; did you mean 'success'?",
    ),
    (
        "unknown parameter",
        """
        root:
          tick_counter: {duration: 2, completion_stat: FAILURE}
        """,
        (2, 31),
        "tick_counter has no parameter 'completion_stat'; did you mean 'completion_status'?",
    ),
    (
        "wrong type",
        """
        root:
          tick_counter:
            duration: "3"
        """,
        (3, 15),
        "tick_counter.duration: expected an integer, got a string '3'",
    ),
    (
        "bad choice",
        """
        root:
          one_shot: {policy: sometimes, child: {success: {}}}
        """,
        (2, 22),
        "one_shot.policy: 'sometimes' is not one of 'on_completion', 'on_successful_completion'",
    ),
    (
        "missing required parameter",
        """
        root:
          sequence:
            - retry: {child: {failure: {}}}
        """,
        (3, 7),
        "retry needs parameter 'num_failures' (failures allowed before failing)",
    ),
    (
        "node with two keys",
        """
        root:
          sequence:
            - success: {}
              failure: {}
        """,
        (3, 7),
        "a node is a mapping with exactly one key",
    ),
    (
        "node that is not a mapping",
        """
        root:
          selector:
            - success
        """,
        (3, 7),
        "a node is a mapping with exactly one key",
    ),
    (
        "composite without children",
        """
        root:
          sequence: {memory: false}
        """,
        (2, 13),
        "sequence needs children",
    ),
    (
        "decorator without child",
        """
        root:
          inverter: {name: x}
        """,
        (2, 13),
        "inverter needs a child node",
    ),
    (
        "leaf given a list",
        """
        root:
          success: [1, 2]
        """,
        (2, 12),
        "success takes a mapping of its parameters",
    ),
    (
        "unbound blackboard key",
        """
        root:
          wait: {seconds: "{delay}"}
        """,
        (2, 19),
        "blackboard key 'delay' is read here but nothing writes it",
    ),
    (
        "binding where py_trees needs a value",
        """
        blackboard: {n: 3}
        root:
          tick_counter: {duration: "{n}"}
        """,
        (3, 28),
        "tick_counter.duration cannot be bound to the blackboard",
    ),
    (
        "parallel selecting an unknown child",
        """
        root:
          parallel:
            policy: success_on_selected
            selected: [a, c]
            children: [{success: {name: a}}, {running: {name: b}}]
        """,
        (2, 3),
        "selected: no child named 'c'",
    ),
    (
        "either_or with too few conditions",
        """
        root:
          either_or:
            conditions: [{variable_name: x, value: 1}]
            children: [{success: {}}, {failure: {}}]
        """,
        (2, 3),
        "conditions: give one per child (2 children, 1 conditions)",
    ),
    (
        "unknown top-level key",
        """
        tick_hz: 10
        blackbord: {a: 1}
        root: {success: {}}
        """,
        (2, 1),
        "unknown tree key 'blackbord'; did you mean 'blackboard'?",
    ),
    (
        "tick rate not positive",
        """
        tick_hz: 0
        root: {success: {}}
        """,
        (1, 10),
        "tick_hz: expected a rate from 0.1 to 1000 Hz",
    ),
    (
        "no root",
        """
        tree: nothing
        """,
        (1, 1),
        "the tree has no root node",
    ),
    (
        "malformed YAML",
        """
        root:
          sequence: [{success: {}}, {failure: {}
        tick_hz: 3
        """,
        (3, 1),
        "invalid YAML",
    ),
    (
        "duplicate key",
        """
        root:
          tick_counter: {duration: 1, duration: 2}
        """,
        (2, 31),
        "key 'duration' is given twice",
    ),
    (
        "missing include file",
        """
        root:
          subtree: {file: nowhere.yaml}
        """,
        (2, 19),
        "subtree file 'nowhere.yaml' not found",
    ),
    (
        "bad subtree option",
        """
        root:
          subtree: {file: other.yaml, whith: {}}
        """,
        (2, 31),
        "subtree has no option 'whith'; did you mean 'with'?",
    ),
]


@pytest.mark.parametrize(("label", "text", "where", "message"), CASES, ids=[c[0] for c in CASES])
def test_each_error_at_its_line_and_column(tmp_path, label, text, where, message):
    write(tmp_path, "other.yaml", "root: {success: {}}\n")
    path = write(tmp_path, "t.yaml", text)
    err = one_error(path)
    assert (err.file, err.line, err.column) == (str(path), *where), err.format()
    assert message in err.message
    assert err.format().startswith(f"{path}:{where[0]}:{where[1]}: ")


def test_all_errors_of_a_file_are_reported_at_once(tmp_path):
    path = write(
        tmp_path,
        "many.yaml",
        """
        tick_hz: fast
        root:
          sequence:
            memroy: true
            children:
              - sucess: {}
              - tick_counter: {duration: 1.5}
              - wait: {seconds: "{later}"}
              - retry: {child: {inverter: {child: {runing: {}}}}}
              - one_shot: {policy: never, child: {success: {}}}
        """,
    )
    errors = errors_of(path)
    where = [(e.line, e.column) for e in errors]
    assert where == [(1, 10), (4, 5), (6, 9), (7, 34), (8, 25), (9, 9), (9, 44), (10, 28)]
    assert all(e.file == str(path) for e in errors)
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_tree(path, manager=core_manager())
    assert len(str(info.value).splitlines()) == len(errors)
    assert isinstance(info.value, ValueError)


def test_include_cycle_is_reported_at_the_include(tmp_path):
    write(tmp_path, "a.yaml", "root:\n  sequence:\n    - subtree: {file: b.yaml}\n")
    write(tmp_path, "b.yaml", "root:\n  selector:\n    - subtree: {file: a}\n")
    err = one_error(tmp_path / "a.yaml")
    assert err.file == str(tmp_path / "b.yaml")
    assert (err.line, err.column) == (3, 23)
    assert "include cycle: a.yaml -> b.yaml -> a.yaml" in err.message
    assert f"included from {tmp_path / 'a.yaml'}:3:7" in err.message


def test_errors_inside_an_included_file_point_into_it(tmp_path):
    write(tmp_path, "main.yaml", "root:\n  sequence:\n    - subtree: {file: inner.yaml}\n")
    write(tmp_path, "inner.yaml", "root:\n  retry: {num_failures: x, child: {success: {}}}\n")
    err = one_error(tmp_path / "main.yaml")
    assert (err.file, err.line, err.column) == (str(tmp_path / "inner.yaml"), 2, 25)
    assert "retry.num_failures: expected an integer" in err.message


def test_constructor_errors_of_a_plugin_behaviour_are_shown_at_the_node(tmp_path):
    class Picky(armtree.Behaviour):
        """Refuses odd sizes."""

        PARAMS = (armtree.Param("size", "int"),)

        def __init__(self, name, **params):
            if params["size"] % 2:
                raise ValueError("size must be even")  # raised here
            super().__init__(name, **params)

        def update(self):
            return py_trees.common.Status.SUCCESS

    class Plugin:
        @armtree.hookimpl
        def armtree_behaviours(self):
            return {"picky": Picky}

    path = write(tmp_path, "t.yaml", "root:\n  sequence:\n    - picky: {size: 3}\n")
    raised = next(
        i
        for i, line in enumerate(Path(__file__).read_text().splitlines(), 1)
        if "# raised here" in line
    )
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_tree(path, manager=core_manager(Plugin()))
    assert (info.value.line, info.value.column) == (3, 7)
    assert info.value.message.startswith("picky 'picky': the constructor of ")
    assert info.value.message.endswith(
        f"Picky (plugin 'test_plugin_0') raised ValueError at {__file__}:{raised}: "
        "size must be even"
    )


def test_output_parameter_needs_a_binding(tmp_path):
    class Finder(armtree.Behaviour):
        """Writes a pose."""

        PARAMS = (armtree.Param("pose", "vector", io="out"),)

        def update(self):
            return py_trees.common.Status.SUCCESS

    class Plugin:
        @armtree.hookimpl
        def armtree_behaviours(self):
            return {"finder": Finder}

    path = write(tmp_path, "t.yaml", "root:\n  finder: {pose: [1, 2, 3]}\n")
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_tree(path, manager=core_manager(Plugin()))
    assert (info.value.line, info.value.column) == (2, 18)
    assert "finder.pose is an output" in info.value.message


def test_unknown_tree_name_suggests_a_shipped_one(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_tree("load_duck", manager=core_manager())
    assert "did you mean 'load_ducky'?" in info.value.message


def test_bad_override_is_an_error(tmp_path):
    path = write(tmp_path, "t.yaml", "root: {success: {}}\n")
    err = one_error(path, overrides=["no_equals_sign"])
    assert err.file == "--set"
    assert "expected KEY=VALUE" in err.message


def test_profile_override_without_a_rig_is_an_error(tmp_path):
    path = write(tmp_path, "t.yaml", "root: {success: {}}\n")
    err = one_error(path, overrides=["arm.type=vicra"])
    assert "the tree names no rig" in err.message
    assert err.file == "--set arm.type=vicra"


def test_a_missing_parameter_is_reported_once_not_where_it_is_used(tmp_path):
    path = write(
        tmp_path,
        "p.yaml",
        """
        params:
          tag: {doc: marker role}
        root:
          sequence:
            name: "Find {tag}"
            children:
              - set_blackboard_variable: {variable_name: "{tag}_seen", variable_value: "{tag}"}
              - wait: {seconds: "{{tag}_delay}"}
        """,
    )
    err = one_error(path)
    assert (err.line, err.column) == (2, 3)
    assert err.message == "p.yaml needs parameter 'tag': give it with --set tag=VALUE"
    tree = armtree.load_tree(path, overrides=["tag=duck", "duck_delay=2"], manager=core_manager())
    assert tree.root.name == "Find duck"
    assert tree.root.children[1].params["seconds"] == armtree.Binding("duck_delay")


@pytest.mark.parametrize("text", ["", "# nothing yet\n"])
def test_an_empty_included_tree_is_an_error_at_the_include(tmp_path, text):
    (tmp_path / "empty.yaml").write_text(text)
    main = tmp_path / "main.yaml"
    main.write_text("tree: main\nroot: {subtree: {file: empty.yaml}}\n")
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_tree(main)
    assert info.value.format() == (
        f"{main}:2:24: subtree file {tmp_path / 'empty.yaml'} is empty; it needs a root node "
        "(tree: NAME, root: ...)"
    )
