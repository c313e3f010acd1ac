"""The documentation stands on its own: generated parts current, links resolving, no outside files."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from armtree.cli import profile_reference
from armtree.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]
DOCS = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]
#: Files that are not in the repository, and machine-specific places, that nothing may cite.
OUTSIDE = re.compile(r"DESIGN\.md|hardware_protocols\.md|reference §|/work/|/home/\w+|\.venv-\w+")


def _tracked_text_files() -> list[Path]:
    listed = subprocess.run(
        ["git", "ls-files", "*.py", "*.md", "*.toml", "*.yaml", "*.txt"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    if listed.returncode != 0:  # not a git checkout (an unpacked sdist): read the folders
        return [
            p
            for d in ("core", "plugins", "tests", "benchmarks", "docs")
            for p in (ROOT / d).rglob("*.py")
        ]
    return [ROOT / name for name in listed.stdout.split()]


def test_profiles_md_component_reference_is_current():
    path = ROOT / "docs" / "profiles.md"
    text = path.read_text()
    assert profile_reference.replace_reference(text, str(path)) == text, (
        "docs/profiles.md's component reference is out of date: run "
        "python -m armtree.cli.profile_reference --update docs/profiles.md"
    )
    assert "#### `arm: {type: dobot_v1}`" in text and "| `l1_mm` | float, mm" in text


def test_profile_reference_update_needs_the_markers(tmp_path, capsys):
    page = tmp_path / "p.md"
    page.write_text("# no markers\n")
    with pytest.raises(ConfigError, match="no component reference markers"):
        profile_reference.replace_reference(page.read_text(), str(page))
    assert profile_reference.main(["--update", str(page)]) == 2
    page.write_text(f"before\n{profile_reference.BEGIN}\nold\n{profile_reference.END}\nafter\n")
    assert profile_reference.main(["--update", str(page)]) == 0
    text = page.read_text()
    assert "\nold\n" not in text and "`tracker: {type: hamming}`" in text
    assert text.startswith("before\n") and text.endswith("after\n")


def _lines_matching(pattern: re.Pattern[str]) -> list[str]:
    """``FILE:LINE: text`` of every tracked line (this file's aside) ``pattern`` finds."""
    this = Path(__file__).resolve()
    return [
        f"{path.relative_to(ROOT)}:{n}: {line.strip()}"
        for path in _tracked_text_files()
        if path.resolve() != this and path.is_file()
        for n, line in enumerate(path.read_text(errors="replace").splitlines(), 1)
        if pattern.search(line)
    ]


def test_nothing_cites_files_outside_the_repository_or_machine_paths():
    found = _lines_matching(OUTSIDE)
    assert found == [], "cite docs/references.md's short names, not these:\n" + "\n".join(found)


#: A source document cited by the number it had in the set it came in, not its short name.
SOURCE_NUMBER = re.compile(r"\b[Ss]eeds? 00[0-9]\b")


def test_source_documents_go_by_their_short_names_and_seed_means_a_random_world():
    found = _lines_matching(SOURCE_NUMBER)
    assert found == [], "cite docs/references.md's short names:\n" + "\n".join(found)


@pytest.mark.parametrize("page", DOCS, ids=lambda p: p.name)
def test_local_links_resolve(page):
    text = page.read_text()
    broken = []
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+:", target):
            continue
        file, _, anchor = target.partition("#")
        dest = (page.parent / file).resolve() if file else page
        if (
            not dest.exists()
            or anchor
            and dest.suffix == ".md"
            and anchor not in _anchors(dest.read_text())
        ):
            broken.append(target)
    assert broken == [], f"{page.name}: links to nothing: {broken}"


def _anchors(markdown: str) -> set[str]:
    """GitHub's heading anchors: lower case, punctuation dropped, spaces as hyphens."""
    out = set()
    for heading in re.findall(r"^#+\s+(.*)$", markdown, re.M):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        out.add(slug)
    return out


def test_profile_reference_runs_as_a_module():
    done = subprocess.run(
        [sys.executable, "-m", "armtree.cli.profile_reference"],
        capture_output=True,
        text=True,
        timeout=120,
        env={"ARMTREE_DISABLE_PLUGIN_AUTOLOAD": "1", "PATH": "/usr/bin:/bin"},
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "### `planner:` types" in done.stdout
