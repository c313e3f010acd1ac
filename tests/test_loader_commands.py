"""The core commands (check, show, plugins, schema) and the JSON Schema of trees and profiles."""

from __future__ import annotations

import argparse
import functools
import json
import textwrap
from pathlib import Path

import jsonschema
import pytest
import yaml

import armtree
from armtree.cli import builtin_commands
from armtree.config.resolve import shipped_dir
from armtree.hooks import builtin_behaviours
from armtree.hooks.plugin_manager import PluginManager, get_plugin_manager
from armtree.loader.schema import build_schema

COMMANDS = builtin_commands.armtree_commands()


def core_manager() -> PluginManager:
    manager = PluginManager(autoload=False)
    manager.register(builtin_behaviours, "core_behaviours")
    manager.register(builtin_commands, "core_commands")
    return manager


def parse(name: str, argv: list[str], manager: PluginManager | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog=f"armtree {name}")
    COMMANDS[name].configure(parser)
    args = parser.parse_args(argv)
    args.manager = manager or core_manager()
    return args


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return path


TREE = """
tree: demo
root:
  selector:
    name: Top
    children:
      - inverter: {child: {success: {name: Never}}}
      - tick_counter: {duration: 2}
"""


def test_every_command_has_help_configure_and_run():
    assert set(COMMANDS) == {"check", "show", "plugins", "schema", "hooks", "new-plugin", "sweep"}
    for command in COMMANDS.values():
        assert command.help and callable(command.configure) and callable(command.run)


def test_check_valid_and_invalid(tmp_path, capsys):
    good = write(tmp_path, "good.yaml", TREE)
    assert COMMANDS["check"].run(parse("check", [str(good)])) == 0
    assert capsys.readouterr().out == "ok: demo: 4 nodes at 20 Hz (no rig)\n"
    bad = write(tmp_path, "bad.yaml", "root: {inverter: {child: {sucess: {}}}}\n")
    with pytest.raises(armtree.ConfigError) as info:
        COMMANDS["check"].run(parse("check", [str(bad), "--set", "x=1"]))
    assert (info.value.line, info.value.column) == (1, 27)


def test_show_ascii_and_dot(tmp_path, capsys):
    path = write(tmp_path, "t.yaml", TREE)
    assert COMMANDS["show"].run(parse("show", [str(path)])) == 0
    text = capsys.readouterr().out
    assert text.splitlines()[0] == "[o] Top"
    assert "-^- inverter" in text and "--> Never" in text
    out = tmp_path / "t.dot"
    assert COMMANDS["show"].run(parse("show", [str(path), "--format", "dot", "-o", str(out)])) == 0
    dot = out.read_text()
    assert dot.startswith("digraph") and '"Never"' in dot or "Never" in dot


def test_show_png_is_a_real_image(tmp_path):
    path = write(tmp_path, "t.yaml", TREE)
    out = tmp_path / "tree.png"
    assert COMMANDS["show"].run(parse("show", [str(path), "--format", "png", "-o", str(out)])) == 0
    data = out.read_bytes()
    assert data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) > 2000


def test_plugins_lists_components_with_plugin_and_parameters(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "400")
    assert COMMANDS["plugins"].run(parse("plugins", ["--kind", "behaviour"])) == 0
    out = capsys.readouterr().out
    assert "tick_counter" in out and "core_behaviours" in out
    assert "duration: int [ticks]" in out
    assert "RUNNING for `duration` ticks" in out
    assert "schema" not in out


def test_schema_command_writes_valid_json_schema(tmp_path, capsys):
    out = tmp_path / "s.json"
    assert COMMANDS["schema"].run(parse("schema", ["-o", str(out)])) == 0
    capsys.readouterr()
    schema = json.loads(out.read_text())
    jsonschema.Draft7Validator.check_schema(schema)
    node_types = {next(iter(alt["properties"])) for alt in schema["definitions"]["node"]["anyOf"]}
    assert node_types == {*builtin_behaviours.node_types(), "subtree"}
    assert COMMANDS["schema"].run(parse("schema", [])) == 0
    assert json.loads(capsys.readouterr().out) == schema


@functools.cache
def _validator() -> jsonschema.Draft7Validator:
    return jsonschema.Draft7Validator(build_schema(get_plugin_manager().registry))


def _shipped() -> list[Path]:
    return sorted(shipped_dir("tree").glob("*.yaml")) + sorted(
        shipped_dir("profile").glob("*.yaml")
    )


@pytest.mark.parametrize("path", _shipped(), ids=lambda p: p.name)
def test_schema_accepts_every_shipped_tree_and_profile(path):
    errors = [e.message for e in _validator().iter_errors(yaml.safe_load(path.read_text()))]
    assert errors == []


@pytest.mark.parametrize(
    "text",
    [
        "root: {sucess: {}}",
        "root: {tick_counter: {duration: x}}",
        "root: {tick_counter: {}}",
        "root: {inverter: {}}",
        "root: {sequence: {memory: true}}",
        "tick_hz: 0\nroot: {success: {}}",
        "rooot: {success: {}}",
        "arm: {}",
        "arm: {type: vicra}\ntags: {a: {size_mm: 0, id: 1}}",
        "arm: {type: vicra}\nplaces: {home: [1, 2]}",
    ],
)
def test_schema_rejects_what_the_loader_rejects(text):
    assert list(_validator().iter_errors(yaml.safe_load(text)))


def test_shipped_trees_reference_the_shipped_schema():
    trees = shipped_dir("tree")
    schema = json.loads((trees / "armtree.schema.json").read_text())
    jsonschema.Draft7Validator.check_schema(schema)
    for path in trees.glob("*.yaml"):
        first = path.read_text().splitlines()[0]
        assert first == "# yaml-language-server: $schema=armtree.schema.json", (
            f"{path.name}: make its first line '# yaml-language-server: $schema=armtree.schema.json'"
            " so editors check it (regenerate with: armtree schema -o trees/armtree.schema.json)"
        )


def _differing_paths(a, b, path: str = "") -> list[str]:
    """JSON paths where two documents differ (a key on one side only counts as a difference)."""
    if isinstance(a, dict) and isinstance(b, dict):
        keys = list(a) + [k for k in b if k not in a]
        return [p for k in keys for p in _differing_paths(a.get(k), b.get(k), f"{path}/{k}")]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [
            p
            for i, (x, y) in enumerate(zip(a, b, strict=True))
            for p in _differing_paths(x, y, f"{path}/{i}")
        ]
    return [] if a == b else [path or "/"]


def test_shipped_schema_is_what_armtree_schema_writes_now():
    shipped = json.loads((shipped_dir("tree") / "armtree.schema.json").read_text())
    current = build_schema(get_plugin_manager(autoload=False).registry)
    paths = _differing_paths(current, shipped)
    assert not paths, (
        f"trees/armtree.schema.json is out of date at {len(paths)} paths, e.g. {paths[:5]}; "
        "regenerate it with: ARMTREE_DISABLE_PLUGIN_AUTOLOAD=1 armtree schema -o trees/armtree.schema.json"
    )


def test_differing_paths_names_each_changed_key():
    a = {"x": {"y": 1, "z": [1, 2]}, "k": 1}
    b = {"x": {"y": 2, "z": [1, 3]}, "n": 1}
    assert _differing_paths(a, b) == ["/x/y", "/x/z/1", "/k", "/n"]
    assert _differing_paths(a, a) == []


def test_armtree_check_in_a_subprocess_exits_0_or_2_with_positions(tmp_path):
    import os
    import subprocess
    import sys

    good = write(tmp_path, "good.yaml", TREE)
    bad = write(tmp_path, "bad.yaml", "root:\n  sequence:\n    - sucess: {}\n    - retry: {}\n")
    code = "import sys; from armtree.cli.commandline import main; sys.exit(main(sys.argv[1:]))"
    env = dict(os.environ, ARMTREE_DISABLE_PLUGIN_AUTOLOAD="1")

    def check(path: Path) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-c", code, "check", str(path)],
            capture_output=True,
            text=True,
            timeout=120,
            env=env,
            cwd=tmp_path,
        )

    ok = check(good)
    assert ok.returncode == 0, ok.stderr
    assert "ok: demo" in ok.stdout
    failed = check(bad)
    assert failed.returncode == 2
    output = failed.stdout + failed.stderr
    assert f"{bad}:3:7: unknown node type 'sucess'; did you mean 'success'?" in output
    assert f"{bad}:4:7: retry needs parameter 'num_failures'" in output
    assert "Traceback" not in output


def test_show_png_uses_graphviz_when_its_dot_program_is_installed(tmp_path, monkeypatch):
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    fake_dot = bin_dir / "dot"
    # A stand-in for Graphviz: records its arguments and the dot source it was given.
    fake_dot.write_text(
        "#!/bin/sh\n"
        'echo "$@" > "$(dirname "$0")/args"\n'
        'for last; do :; done; cp "$last" "$(dirname "$0")/source.dot"\n'
        'printf "PNG from dot" > "$3"\n'
    )
    fake_dot.chmod(0o755)
    monkeypatch.setenv("PATH", f"{bin_dir}:/usr/bin:/bin")
    path = write(tmp_path, "t.yaml", TREE)
    out = tmp_path / "tree.png"
    assert COMMANDS["show"].run(parse("show", [str(path), "--format", "png", "-o", str(out)])) == 0
    assert out.read_text() == "PNG from dot"
    assert (bin_dir / "args").read_text().startswith(f"-Tpng -o {out} ")
    assert "Never" in (bin_dir / "source.dot").read_text()


def test_check_refuses_a_tree_without_a_rig_whose_skills_need_an_arm(tmp_path, capsys):
    tree = write(
        tmp_path,
        "arm.yaml",
        """
        tree: moves
        root:
          sequence:
            children:
              - success: {}
              - home: {}
        """,
    )
    manager = get_plugin_manager(autoload=False)
    with pytest.raises(armtree.ConfigError) as err:
        COMMANDS["check"].run(parse("check", [str(tree)], manager))
    assert (err.value.file, err.value.line) == (str(tree), 6)  # the home node's line
    assert "home needs a rig with an arm" in err.value.message and "--rig" in err.value.message
    # with a rig given the same tree is fine, and a tree of plain behaviours needs none
    assert COMMANDS["check"].run(parse("check", [str(tree), "--rig", "sim_dobot"], manager)) == 0
    plain = write(tmp_path, "plain.yaml", TREE)
    assert COMMANDS["check"].run(parse("check", [str(plain)], manager)) == 0
    assert "(no rig)" in capsys.readouterr().out
