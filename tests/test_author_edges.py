"""The edges a plugin author and a user meet (issue 29): messages in YAML's words, the
workspace of a scaffolded arm, and every command given bad input: a clear line, exit 2."""

from __future__ import annotations

import argparse
import re

import pytest
from plugin_author import armtree

from armtree.cli import commandline as cli
from armtree.config.yamlio import MarkedDict, MarkedList
from armtree.errors import ConfigError, yaml_kind

#: What a user must never read: a traceback, or Python's name for a value's type.
INTERNAL = re.compile(
    r"Traceback|\bMarked(List|Dict)\b|\bNoneType\b|<class '|\b(got|expected) (str|int|float|"
    r"bool|list|dict|tuple)\b"
)


def test_a_value_of_the_wrong_type_is_named_in_yamls_words(tmp_path):
    done = armtree(
        tmp_path, "check", "load_ducky.yaml", "--rig", "sim_magician", "--set", "arm.type=dobot_v1"
    )
    assert done.returncode == 2
    assert "arm.tool_offset_mm: expected a number, got a list [59.7, 0, 70]" in done.stderr
    assert not INTERNAL.search(done.stderr), done.stderr


@pytest.mark.parametrize(
    ("value", "words"),
    [
        (None, "null"),
        (True, "a boolean"),
        (3, "an integer"),
        (2.5, "a number"),
        ("x", "a string"),
        (MarkedList([1, 2]), "a list"),
        (MarkedDict({"a": 1}), "a mapping"),
        ((1, 2), "a list"),
    ],
)
def test_yaml_kind_names_values_as_a_yaml_file_writes_them(value, words):
    assert yaml_kind(value) == words


def test_armtree_workspace_covers_the_scaffolded_scara_arm_as_the_docs_say(tmp_path):
    assert cli.main(["new-plugin", "cheapo_scara", "--kind", "arm", "--dir", str(tmp_path)]) == 0
    package = tmp_path / "armtree-cheapo-scara"
    done = armtree(
        package,
        "workspace",
        "--rig",
        "hardware/sim_cheapo_scara.yaml",
        "--plugin",
        "armtree_cheapo_scara.plugin",
        "--delta",
        "25",
        env={"PYTHONPATH": str(package / "src")},
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("cheapo_scara workspace (model) to 25 mm")
    for place in ("home", "ducky_pickup", "drop_off"):
        assert re.search(rf"place {place} \[.*\] mm: reachable", done.stdout), done.stdout


def test_an_arm_that_describes_no_workspace_is_told_how_at_its_profile_line(monkeypatch):
    from armtree.plugins.planners import workspace_command

    class NoShape:
        """A kinematic model that describes no workspace."""

        name = "blob"

    monkeypatch.setattr(workspace_command, "arm_model", lambda profile, manager=None: NoShape())
    args = argparse.Namespace(delta=5.0, rig="sim_dobot", overrides=[], plot=None)
    with pytest.raises(ConfigError) as info:
        workspace_command.WorkspaceCommand().run(args)
    assert re.fullmatch(
        r".*sim_dobot\.yaml:\d+:\d+: arm\.type: arm 'blob' does not describe its workspace as "
        r"constraints, so it cannot be covered: give its model workspace_shape\(\) "
        r"\(docs/plugins\.md, 'The workspace'\)",
        info.value.format(),
    ), info.value.format()


#: Each subcommand given bad input: its arguments and what its one line says.
EDGES = [
    (["check", "nope.yaml"], "no tree 'nope.yaml' in the working directory"),
    (["check", "load_ducky.yaml", "--rig", "nope"], "--rig nope: no hardware profile 'nope'"),
    (["check", "load_ducky.yaml", "--set", "arm"], "--set: expected KEY=VALUE"),
    (["check", "load_ducky.yaml", "--set", "arm.type=nope"], "unknown arm type 'nope'"),
    (["show", "nope.yaml"], "no tree 'nope.yaml'"),
    (
        ["show", "load_ducky.yaml", "-o", "/proc/no/tree.txt"],
        "-o /proc/no/tree.txt: no folder /proc/no",
    ),
    (["run", "nope.yaml"], "no tree 'nope.yaml'"),
    (["run", "load_ducky.yaml", "--seed", "-1"], "argument --seed: -1 is not a seed"),
    (["run", "load_ducky.yaml", "--seed", "x"], "argument --seed: 'x' is not a seed"),
    (
        ["run", "load_ducky.yaml", "--record", "/proc/no/run"],
        "--record /proc/no/run: cannot write there (No such file",
    ),
    (["sweep", "load_ducky.yaml", "--seeds", "x"], "--seeds x: give a range A-B"),
    (["sweep", "load_ducky.yaml", "--seeds", "1-2", "--rig", "nope"], "no hardware profile"),
    (["workspace", "--rig", "nope"], "no hardware profile 'nope'"),
    (["workspace", "--rig", "sim_dobot", "--set", "arm.type=nope"], "unknown arm type 'nope'"),
    (["calibrate", "kinematics", "--rig", "nope"], "no hardware profile 'nope'"),
    (["calibrate", "kinematics", "--rig", "sim_dobot", "--seed", "-2"], "-2 is not a seed"),
    (["experiment", "accuracy", "--rig", "nope"], "no hardware profile 'nope'"),
    (["jog", "--rig", "nope"], "no hardware profile 'nope'"),
    (["serve-sim", "nope"], "no hardware profile 'nope'"),
    (["serve-sim", "sim_dobot", "--seed", "-3"], "-3 is not a seed"),
    (["emulate", "nope"], "emulate: unknown arm type 'nope'"),
    (["emulate", "dobot_v1", "--seed", "-1"], "-1 is not a seed"),
    (["replay", "nope"], "nope: no such directory"),
    (["detect", "--tracker", "nope", "x.png"], "unknown tracker 'nope'"),
    (["markers", "--family", "aruco", "--id", "-1", "-o", "m.png"], "4x4_50 has ids 0 to 49"),
    (["markers", "--family", "aruco", "--id", "1", "-o", "/proc/no/m.png"], "no folder /proc/no"),
    (["schema", "-o", "/proc/no/s.json"], "cannot write the schema"),
    (["new-plugin", "2fast", "--kind", "skill"], "'2fast' is not a plugin name"),
    (["plugins", "--kind", "nope"], "argument --kind: invalid choice: 'nope'"),
    (["bench", "nope"], "unknown benchmark 'nope'"),
]


@pytest.mark.parametrize(("argv", "said"), EDGES, ids=[" ".join(a) for a, _ in EDGES])
def test_a_command_given_bad_input_says_so_in_one_line_and_exits_2(
    argv, said, tmp_path, monkeypatch, capsys
):
    monkeypatch.chdir(tmp_path)
    try:
        code = cli.main(argv)
    except SystemExit as exc:  # argparse's own usage errors
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2, err
    assert said in err, err
    assert not INTERNAL.search(err), err
    assert not err.startswith("<input>"), err
