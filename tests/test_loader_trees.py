"""Valid trees: structure, every built-in node type, subtrees with parameters, overrides, timers."""

from __future__ import annotations

import textwrap
from pathlib import Path

import py_trees
import pytest
from py_trees.common import Status

import armtree
from armtree.api.clock import VirtualClock
from armtree.config.params import Binding
from armtree.config.resolve import resolve
from armtree.hooks import builtin_behaviours
from armtree.hooks.plugin_manager import PluginManager


def core_manager(*plugins: object) -> PluginManager:
    manager = PluginManager(autoload=False)
    manager.register(builtin_behaviours, "core_behaviours")
    for i, plugin in enumerate(plugins):
        manager.register(plugin, f"test_plugin_{i}")
    return manager


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return path


def load(path: Path, *plugins: object, **kwargs) -> armtree.Tree:
    return armtree.load_tree(path, manager=core_manager(*plugins), **kwargs)


class Reader(armtree.Behaviour):
    """Reads a target, writes a result."""

    PARAMS = (
        armtree.Param("target", "any"),
        armtree.Param("result", "any", None, io="out"),
        armtree.Param("speed", "float", 1.0, unit="mm/s"),
    )

    def update(self) -> Status:
        self.output("result", self.param("target"))
        return Status.SUCCESS


class ReaderPlugin:
    @armtree.hookimpl
    def armtree_behaviours(self):
        return {"reader": Reader}


def test_structure_defaults_and_node_info(tmp_path):
    path = write(
        tmp_path,
        "t.yaml",
        """
        tree: demo
        description: A demo.
        tick_hz: 12.5
        blackboard: {count: 3}
        root:
          sequence:
            name: Main
            children:
              - selector: [{failure: {}}, {success: {name: ok}}]
              - parallel:
                  policy: success_on_one
                  children: [{success: {}}, {running: {}}]
              - success: {}
              - success:
        """,
    )
    tree = load(path)
    assert (tree.name, tree.description, tree.tick_hz, tree.blackboard) == (
        "demo",
        "A demo.",
        12.5,
        {"count": 3},
    )
    assert tree.source == path.resolve() and tree.profile is None
    root = tree.root
    assert isinstance(root, py_trees.composites.Sequence) and root.memory is True
    selector, parallel, s1, s2 = root.children
    assert isinstance(selector, py_trees.composites.Selector) and selector.memory is False
    assert isinstance(parallel.policy, py_trees.common.ParallelPolicy.SuccessOnOne)
    paths = {
        info.path: (info.type, info.mark.line, info.mark.column) for info in tree.nodes.values()
    }
    assert paths["Main"] == ("sequence", 6, 3)
    assert paths["Main/selector/ok"] == ("success", 9, 36)
    assert paths["Main/success"] == ("success", 13, 9)
    assert paths["Main/success#2"] == ("success", 14, 9)
    assert tree.info(s2).path == "Main/success#2"
    assert len(tree.nodes) == len(list(root.iterate()))


def test_parallel_policies_and_memory(tmp_path):
    path = write(
        tmp_path,
        "t.yaml",
        """
        root:
          sequence:
            - parallel: {memory: false, children: [{success: {}}]}
            - parallel:
                policy: success_on_selected
                selected: [b]
                children: [{running: {name: a}}, {success: {name: b}}]
        """,
    )
    first, second = load(path).root.children
    assert isinstance(first.policy, py_trees.common.ParallelPolicy.SuccessOnAll)
    assert first.policy.synchronise is False
    assert [c.name for c in second.policy.children] == ["b"]
    assert second.policy.synchronise is True


#: A minimal valid spec for every built-in node type.
EXAMPLES = {
    "sequence": "[{success: {}}]",
    "selector": "{memory: true, children: [{success: {}}]}",
    "parallel": "[{success: {}}]",
    "success": "{}",
    "failure": "{}",
    "running": "{}",
    "dummy": "{}",
    "periodic": "{n: 2}",
    "success_every_n": "{n: 3}",
    "status_queue": "{queue: [RUNNING, SUCCESS], eventually: FAILURE}",
    "tick_counter": "{duration: 2, completion_status: FAILURE}",
    "blackboard_to_status": "{variable_name: st}",
    "check_blackboard_variable_exists": "{variable_name: x}",
    "wait_for_blackboard_variable": "{variable_name: x}",
    "unset_blackboard_variable": "{key: x}",
    "set_blackboard_variable": "{variable_name: x, variable_value: [1, 2]}",
    "check_blackboard_variable_value": "{variable_name: x, value: 3, operator: ge}",
    "wait_for_blackboard_variable_value": "{variable_name: x, value: 3}",
    "compare_blackboard_variables": "{var1_key: x, var2_key: y, operator: lt}",
    "check_blackboard_variable_values": (
        "{checks: [{variable_name: x, value: 1}, {variable_name: y, value: 2, operator: gt}],"
        " logical_operator: or}"
    ),
    "probabilistic_behaviour": "{weights: [1, 0, 0]}",
    "timer": "{duration: 0.5}",
    "wait": "{seconds: 1}",
    "inverter": "{child: {success: {}}}",
    "pass_through": "{child: {success: {}}}",
    "count": "{child: {success: {}}}",
    "running_is_failure": "{child: {running: {}}}",
    "running_is_success": "{child: {running: {}}}",
    "failure_is_success": "{child: {failure: {}}}",
    "failure_is_running": "{child: {failure: {}}}",
    "success_is_failure": "{child: {success: {}}}",
    "success_is_running": "{child: {success: {}}}",
    "repeat": "{num_success: 2, child: {success: {}}}",
    "retry": "{num_failures: 2, child: {failure: {}}}",
    "status_to_blackboard": "{variable_name: st, child: {success: {}}}",
    "eternal_guard": "{variable_name: ok, child: {running: {}}}",
    "timeout": "{duration: 2, child: {running: {}}}",
    "one_shot": "{policy: on_successful_completion, child: {success: {}}}",
    "condition": "{status: SUCCESS, child: {success: {}}}",
    "for_each": "{source_key: items, target_key: item, child: {success: {}}}",
    "pick_up_where_you_left_off": "[{success: {}}, {running: {}}]",
    "either_or": (
        "{conditions: [{variable_name: x, value: 1}, {variable_name: x, value: 2}],"
        " children: [{success: {}}, {failure: {}}]}"
    ),
}


def test_every_builtin_type_has_an_example():
    assert set(EXAMPLES) == set(builtin_behaviours.node_types())


@pytest.mark.parametrize("ntype", sorted(EXAMPLES))
def test_every_builtin_type_builds_and_ticks(tmp_path, ntype):
    path = write(tmp_path, "t.yaml", f"root:\n  {ntype}: {EXAMPLES[ntype]}\n")
    tree = load(path)
    assert tree.info(tree.root).type == ntype
    assert all(tree.info(node) is not None for node in tree.root.iterate())
    blackboard = py_trees.blackboard.Blackboard
    blackboard.set("/st", Status.SUCCESS)
    blackboard.set("/items", [1, 2])
    blackboard.set("/x", 1)
    py_trees.trees.setup(tree.root, clock=VirtualClock())
    for _ in range(3):
        tree.root.tick_once()
    assert tree.root.status in (Status.SUCCESS, Status.FAILURE, Status.RUNNING)


def test_builtin_semantics_from_yaml(tmp_path):
    path = write(
        tmp_path,
        "t.yaml",
        """
        root:
          sequence:
            - set_blackboard_variable: {variable_name: n, variable_value: 5}
            - check_blackboard_variable_value: {variable_name: n, value: 4, operator: gt}
            - retry: {num_failures: 3, child: {status_queue: {queue: [FAILURE, FAILURE], eventually: SUCCESS}}}
            - inverter: {child: {failure: {}}}
        """,
    )
    root = load(path).root
    root.setup()
    statuses = []
    for _ in range(4):
        root.tick_once()
        statuses.append(root.status)
    assert statuses[-1] == Status.SUCCESS
    assert Status.FAILURE not in statuses


def test_timeout_and_wait_follow_the_run_clock(tmp_path):
    path = write(
        tmp_path,
        "t.yaml",
        """
        root:
          parallel:
            policy: success_on_one
            children:
              - timeout: {duration: 2.0, child: {running: {}}}
              - wait: {seconds: 1.5}
        """,
    )
    tree = load(path)
    clock = VirtualClock()
    py_trees.trees.setup(tree.root, clock=clock)
    timeout, wait = tree.root.children
    tree.root.tick_once()
    assert (timeout.status, wait.status) == (Status.RUNNING, Status.RUNNING)
    clock.advance(1.49)
    tree.root.tick_once()
    assert wait.status == Status.RUNNING
    clock.advance(0.01)
    tree.root.tick_once()
    assert wait.status == Status.SUCCESS
    only_timeout = load(
        write(tmp_path, "u.yaml", "root: {timeout: {duration: 2.0, child: {running: {}}}}\n")
    )
    clock = VirtualClock()
    py_trees.trees.setup(only_timeout.root, clock=clock)
    only_timeout.root.tick_once()
    clock.advance(1.99)
    only_timeout.root.tick_once()
    assert only_timeout.root.status == Status.RUNNING
    clock.advance(0.01)
    only_timeout.root.tick_once()
    assert only_timeout.root.status == Status.FAILURE
    assert only_timeout.root.decorated.status == Status.INVALID


def test_bindings_reach_armtree_behaviours(tmp_path):
    path = write(
        tmp_path,
        "t.yaml",
        """
        blackboard: {goal: [1, 2, 3]}
        root:
          sequence:
            - reader: {target: "{goal}", result: "{copy}", speed: 2}
            - reader: {target: "{copy}"}
        """,
    )
    tree = load(path, ReaderPlugin())
    first, second = tree.root.children
    assert first.params == {"target": Binding("goal"), "result": Binding("copy"), "speed": 2.0}
    assert second.params["result"] is None and second.params["speed"] == 1.0


def test_subtree_parameters_substitute_remap_and_interpolate(tmp_path):
    write(
        tmp_path,
        "find.yaml",
        """
        tree: find
        params:
          tag: {doc: marker role}
          speed: {default: 0.5}
          source: {default: "{home}"}
        blackboard: {home: [0, 0, 0]}
        root:
          sequence:
            name: "Find the {tag}"
            children:
              - reader: {target: "{source}", result: "{{tag}_pose}", speed: "{speed}"}
        """,
    )
    path = write(
        tmp_path,
        "main.yaml",
        """
        blackboard: {start: [1, 1, 1]}
        root:
          sequence:
            - subtree: {file: find.yaml, with: {tag: duckybot, source: "{start}"}}
            - subtree: {file: find, with: {tag: ducky, speed: 2}, name: Second}
            - reader: {target: "{duckybot_pose}"}
            - reader: {target: "{ducky_pose}"}
        """,
    )
    tree = load(path, ReaderPlugin())
    first, second, _, _ = tree.root.children
    assert first.name == "Find the duckybot" and second.name == "Second"
    r1, r2 = first.children[0], second.children[0]
    assert r1.params == {
        "target": Binding("start"),
        "result": Binding("duckybot_pose"),
        "speed": 0.5,
    }
    assert r2.params == {"target": Binding("home"), "result": Binding("ducky_pose"), "speed": 2.0}
    assert tree.blackboard == {"start": [1, 1, 1], "home": [0, 0, 0]}
    info = tree.info(r1)
    assert info.path == "sequence/Find the duckybot/reader"
    assert info.mark.file == str(tmp_path / "find.yaml") and info.mark.line == 11


def test_subtree_parameter_errors(tmp_path):
    write(
        tmp_path, "p.yaml", "params: {tag: {}, n: {default: 1}}\nroot: {success: {name: '{tag}'}}\n"
    )
    write(tmp_path, "q.yaml", "root: {success: {name: '{tag}'}}\n")
    path = write(
        tmp_path,
        "main.yaml",
        """
        root:
          sequence:
            - subtree: {file: p.yaml, with: {tga: x}}
            - subtree: {file: q.yaml, with: {tag: x, colour: red}}
        """,
    )
    with pytest.raises(armtree.ConfigError) as info:
        load(path)
    messages = [(e.line, e.column, e.message) for e in info.value.errors]
    assert (3, 38, "p.yaml has no parameter 'tga'; did you mean 'tag'?") in messages
    assert any(
        m.startswith("p.yaml needs parameter 'tag'") and (ln, c) == (3, 7) for ln, c, m in messages
    )
    assert (4, 46, "q.yaml does not use parameter 'colour' (no {colour} in it)") in messages


def test_nested_subtrees_pass_parameters_down(tmp_path):
    write(tmp_path, "leaf.yaml", "params: [delay]\nroot: {wait: {seconds: '{delay}'}}\n")
    write(
        tmp_path,
        "mid.yaml",
        "params: [t]\nroot: {subtree: {file: leaf.yaml, with: {delay: '{t}'}}}\n",
    )
    path = write(tmp_path, "top.yaml", "root: {subtree: {file: mid.yaml, with: {t: 2.5}}}\n")
    tree = load(path)
    assert tree.root.params == {"seconds": 2.5}


def test_top_level_parameters_and_blackboard_overrides(tmp_path):
    path = write(
        tmp_path,
        "t.yaml",
        """
        params: {delay: {default: 1}}
        blackboard: {goal: {x: 1}}
        root:
          sequence:
            - wait: {seconds: "{delay}"}
            - wait: {seconds: "{pause}"}
        """,
    )
    tree = load(path, overrides=["delay=3.5", "pause=2", "goal.y=[1, 2]"])
    assert tree.root.children[0].params == {"seconds": 3.5}
    assert tree.root.children[1].params == {"seconds": Binding("pause")}
    assert tree.blackboard == {"goal": {"x": 1, "y": [1, 2]}, "pause": 2}


def test_a_set_key_no_node_reads_is_an_error_with_did_you_mean(tmp_path):
    path = write(
        tmp_path,
        "t.yaml",
        """
        blackboard: {clean_up: true}
        root:
          sequence:
            - check_blackboard_variable_value: {variable_name: clean_up, value: true}
            - wait: {seconds: "{pause}"}
            - eternal_guard: {variable_name: armed.ready, child: {success: {}}}
        """,
    )
    with pytest.raises(armtree.ConfigError) as info:
        load(path, overrides=["pause=1", "clean_upp=false", "flag=yes"])
    messages = [(e.file, e.message) for e in info.value.errors]
    assert [file for file, _ in messages] == ["--set clean_upp=false", "--set flag=yes"]
    assert "no node of this tree reads blackboard key 'clean_upp'" in messages[0][1]
    assert "did you mean 'clean_up'?" in messages[0][1]
    # keys read by a binding, named by a py_trees blackboard behaviour or declared are fine
    tree = load(path, overrides=["pause=1", "clean_up=false", "armed={ready: true}"])
    assert tree.blackboard == {"clean_up": False, "pause": 1, "armed": {"ready": True}}


def test_names_resolve_in_the_working_directory_then_the_shipped_trees(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shipped = resolve("load_ducky", "tree")
    assert (
        shipped is not None and shipped.parent.name == "trees" and shipped.name == "load_ducky.yaml"
    )
    assert resolve("sim_dobot.yaml", "profile").parent.name == "hardware"
    write(tmp_path, "load_ducky.yaml", "tree: mine\nroot: {success: {}}\n")
    assert resolve("load_ducky", "tree") == tmp_path / "load_ducky.yaml"
    profile = armtree.Profile(name="fake", source=None, data={"arm": {"type": "x"}})
    tree = load(Path("load_ducky"), rig=profile)
    assert tree.name == "mine" and tree.profile is profile


def test_plugins_listed_in_a_tree_are_loaded_relative_to_it(tmp_path):
    (tmp_path / "sub").mkdir()
    write(
        tmp_path / "sub",
        "my_nodes.py",
        """
        import armtree
        from py_trees.common import Status


        class Hello(armtree.Behaviour):
            \"\"\"Says hello.\"\"\"

            PARAMS = (armtree.Param("greeting", "str", "hello"),)

            def update(self):
                return Status.SUCCESS


        @armtree.hookimpl
        def armtree_behaviours():
            return {"hello": Hello}
        """,
    )
    path = write(
        tmp_path / "sub", "t.yaml", "plugins: [my_nodes.py]\nroot: {hello: {greeting: hi}}\n"
    )
    tree = load(path)
    assert tree.root.params == {"greeting": "hi"}
    assert tree.plugins == [str(tmp_path / "sub" / "my_nodes.py")]
    bad = write(tmp_path, "bad.yaml", "plugins: [not_a_module_xyz]\nroot: {success: {}}\n")
    with pytest.raises(armtree.ConfigError) as info:
        load(bad)
    assert (info.value.line, info.value.column) == (1, 11)
    assert "plugin 'not_a_module_xyz' failed to import" in info.value.message


def test_tick_rate_override(tmp_path):
    path = write(tmp_path, "t.yaml", "tick_hz: 10\nroot: {success: {}}\n")
    assert load(path, overrides=["tick_hz=50"]).tick_hz == 50.0
    with pytest.raises(armtree.ConfigError) as info:
        load(path, overrides=["tick_hz=-5"])
    assert (
        info.value.file == "--set tick_hz=-5"
        and "tick_hz: expected a rate from 0.1 to 1000 Hz" in info.value.message
    )


def test_subtree_namespace_keeps_its_own_keys_apart(tmp_path):
    write(
        tmp_path,
        "scan.yaml",
        """
        params: [out]
        blackboard: {step: 5}
        root:
          sequence:
            - reader: {target: "{step}", result: "{scratch}"}
            - reader: {target: "{scratch}", result: "{out}"}
            - reader: {target: "{/shared}"}
        """,
    )
    path = write(
        tmp_path,
        "main.yaml",
        """
        blackboard: {shared: 1}
        root:
          sequence:
            - subtree: {file: scan.yaml, namespace: left, with: {out: "{left_result}"}}
            - subtree: {file: scan.yaml, namespace: right, with: {out: "{right_result}"}}
            - reader: {target: "{left_result}"}
            - reader: {target: "{right/scratch}"}
        """,
    )
    tree = load(path, ReaderPlugin())
    left, right, _, _ = tree.root.children
    assert [c.params["target"] for c in left.children] == [
        Binding("left/step"),
        Binding("left/scratch"),
        Binding("/shared"),
    ]
    assert [c.params["result"] for c in right.children[:2]] == [
        Binding("right/scratch"),
        Binding("right_result"),
    ]
    assert tree.blackboard == {"shared": 1, "left/step": 5, "right/step": 5}
    bad = write(tmp_path, "bad.yaml", "root: {subtree: {file: scan.yaml, namespace: 'a b'}}\n")
    with pytest.raises(armtree.ConfigError) as info:
        load(bad, ReaderPlugin())
    assert any("subtree namespace: expected a name" in e.message for e in info.value.errors)
