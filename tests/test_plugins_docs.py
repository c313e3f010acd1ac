"""docs/plugins.md: its hook reference matches the hookspecs, and its first example does what it says."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import armtree
from armtree.cli.commandline import main
from armtree.cli.hook_reference import BEGIN, END, hook_reference, replace_reference, update_file

DOC = Path(__file__).resolve().parents[1] / "docs" / "plugins.md"


def test_the_hook_reference_is_generated_from_the_current_hookspecs():
    text = DOC.read_text()
    assert replace_reference(text) == text, (
        "docs/plugins.md's hook reference differs from core/hooks/hookspecs.py: "
        "run `armtree hooks --update docs/plugins.md`"
    )
    for name in vars(armtree.hooks.hookspecs):
        if name.startswith("armtree_"):
            assert f"#### `{name}(" in text


def test_hooks_update_rewrites_only_the_part_between_the_markers(tmp_path, capsys):
    stale = tmp_path / "plugins.md"
    stale.write_text(f"# Intro\n\n{BEGIN}\nold text\n{END}\n\nafter\n")
    assert main(["hooks", "--update", str(stale)]) == 0
    assert capsys.readouterr().out.strip() == f"updated: {stale}"
    text = stale.read_text()
    assert text.startswith(f"# Intro\n\n{BEGIN}\n") and text.endswith(f"{END}\n\nafter\n")
    assert hook_reference() in text and "old text" not in text
    assert update_file(stale) is False
    (tmp_path / "bare.md").write_text("no markers\n")
    assert main(["hooks", "--update", str(tmp_path / "bare.md")]) == 2
    assert "has no hook reference markers" in capsys.readouterr().err


def test_the_reference_turns_rest_into_markdown():
    text = hook_reference()
    assert "#### `armtree_rig_ready(rig: Rig, context: RigContext) -> None`" in text
    assert "- `rig`: the `armtree.api.rig.Rig` about to be handed to the tree." in text
    assert ":class:" not in text and "``" not in text


@pytest.fixture
def first_example(tmp_path: Path) -> Path:
    """The page's opening plugin file and tree, as written."""
    blocks = re.findall(r"```(?:python|yaml)\n(.*?)```", DOC.read_text(), re.S)
    (tmp_path / "my_skills.py").write_text(blocks[0])
    (tmp_path / "hello.yaml").write_text(blocks[1])
    return tmp_path


def test_the_first_example_runs_and_its_mistake_is_reported_as_shown(first_example, capsys):
    hello = first_example / "hello.yaml"
    assert main(["run", str(hello), "--record", str(first_example / "run")]) == 0
    assert "sequence/beep: INVALID -> SUCCESS  (hello)" in capsys.readouterr().out
    bad = first_example / "bad.yaml"
    bad.write_text(hello.read_text().replace("{text: hello}", "{txt: hi}"))
    assert main(["check", str(bad)]) == 2
    shown = re.search(
        r"refused at load, exit 2, nothing run:\n\n```\n(.*?)```", DOC.read_text(), re.S
    )
    assert capsys.readouterr().err == shown.group(1).replace("hello.yaml", str(bad))
