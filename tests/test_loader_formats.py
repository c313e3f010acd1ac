"""Tree files in another format: a plugin's ``armtree_read_tree`` gives the loader the data
a YAML file would, and every check and FILE:LINE:COL error applies to it unchanged."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

import armtree
from armtree.config.yamlio import load_yaml
from armtree.hooks import builtin_behaviours
from armtree.hooks.plugin_manager import PluginManager


class SectionsReader:
    """A toy multi-tree format: ``--- ID`` lines start each tree (YAML below); the first
    is the file's own. Positions are kept: each tree's YAML is parsed padded to its line."""

    @armtree.hookimpl
    def armtree_read_tree(self, path: Path):
        name, _, wanted = path.name.partition("#")
        real = path.with_name(name)
        if real.suffix != ".trees":
            return None
        lines = real.read_text().splitlines()
        starts = [i for i, line in enumerate(lines) if line.startswith("--- ")]
        ids = [lines[i][4:].strip() for i in starts]
        index = ids.index(wanted) if wanted else 0
        end = starts[index + 1] if index + 1 < len(starts) else len(lines)
        text = "\n" * (starts[index] + 1) + "\n".join(lines[starts[index] + 1 : end])
        return load_yaml(text, str(real))


def manager() -> PluginManager:
    m = PluginManager(autoload=False)
    m.register(builtin_behaviours, "core_behaviours")
    m.register(SectionsReader(), "sections")
    return m


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "t.trees"
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return path


def test_a_plugin_format_loads_with_subtrees_of_the_same_file(tmp_path):
    path = write(
        tmp_path,
        """
        --- main
        tree: main
        root:
          sequence:
            - subtree: {file: "#inner", with: {n: 2}}
            - success: {}
        --- inner
        root: {tick_counter: {name: "count {n}", duration: "{n}"}}
        """,
    )
    tree = armtree.load_tree(path, manager=manager())
    assert tree.name == "main"
    types = sorted((i.path, i.type, i.params.get("duration")) for i in tree.nodes.values())
    assert types == [
        ("sequence", "sequence", None),
        ("sequence/count 2", "tick_counter", 2),
        ("sequence/success", "success", None),
    ]
    counter = next(i for i in tree.nodes.values() if i.type == "tick_counter")
    assert (Path(counter.mark.file).name, counter.mark.line) == ("t.trees", 8)


def test_errors_in_a_plugin_format_name_its_file_line_and_column(tmp_path):
    path = write(
        tmp_path,
        """
        --- main
        root:
          sequence:
            - subtree: {file: "#inner"}
            - sucess: {}
        --- inner
        root: {subtree: {file: "#main"}}
        """,
    )
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_tree(path, manager=manager())
    found = [(e.line, e.column, e.message) for e in info.value.errors]
    assert found[-1][:2] == (5, 7) and "unknown node type 'sucess'" in found[-1][2]
    assert "did you mean 'success'" in found[-1][2]
    # the top-level file is t.trees itself, so the cycle shows from its first repeat
    cycle = [f for f in found if f[2].startswith("include cycle")]
    assert cycle[0][:2] == (4, 23)
    assert "t.trees#inner -> t.trees#main -> t.trees#inner" in cycle[0][2]


def test_a_file_no_plugin_claims_is_read_as_yaml(tmp_path):
    path = tmp_path / "t.txt"
    path.write_text("root: {success: {}}\n")
    tree = armtree.load_tree(path, manager=manager())
    assert [i.type for i in tree.nodes.values()] == ["success"]
