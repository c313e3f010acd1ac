"""The wheel's package list matches the folders, so nothing is left out of an install."""

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MAPPING = {
    "core": "armtree",
    "plugins": "armtree.plugins",
    "trees": "armtree.trees",
    "hardware": "armtree.hardware",
}


def _packages_on_disk() -> set[str]:
    found = set()
    for folder, name in MAPPING.items():
        for init in (ROOT / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(ROOT / folder)
            found.add(".".join([name, *rel.parts]) if rel.parts else name)
    return found


def test_every_package_folder_is_listed_in_pyproject():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    listed = set(config["tool"]["setuptools"]["packages"])
    assert _packages_on_disk() - listed == set(), "add these packages to pyproject.toml"
    assert listed - _packages_on_disk() == set(), "these listed packages have no __init__.py"


def test_every_entry_point_module_exists():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    for name, target in config["project"]["entry-points"]["armtree"].items():
        parts = target.split(".")
        folder = {"armtree": "core"}[parts[0]]
        if parts[1] == "plugins":
            path = ROOT / "plugins" / Path(*parts[2:])
        else:
            path = ROOT / folder / Path(*parts[1:])
        assert path.with_suffix(".py").is_file(), f"entry point {name} -> {target} has no module"


def _requirement_blocks(text: str) -> dict[str, list[tuple[str, list[str]]]]:
    """Each dependency list of pyproject.toml: its requirements with the comment lines above."""
    blocks: dict[str, list[tuple[str, list[str]]]] = {}
    name, comments = None, []
    for raw in text.splitlines():
        line = raw.strip()
        if line.endswith("= [") and not line.startswith("#"):
            name, comments = line.split("=")[0].strip(), []
            blocks[name] = []
        elif name and line.startswith("]"):
            name = None
        elif name and line.startswith("#"):
            comments.append(line)
        elif name and line.startswith('"'):
            blocks[name].append((line.strip('",'), comments))
            comments = []
    return blocks


def test_every_dependency_says_why_it_is_there():
    blocks = _requirement_blocks((ROOT / "pyproject.toml").read_text())
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert [r for r, _ in blocks["dependencies"]] == config["project"]["dependencies"]
    for extra, requirements in config["project"]["optional-dependencies"].items():
        assert [r for r, _ in blocks[extra]] == requirements
    bare = [
        (block, requirement)
        for block, requirements in blocks.items()
        if block == "dependencies" or block in config["project"]["optional-dependencies"]
        for requirement, comments in requirements
        if not comments and not requirement.startswith(("setuptools", "wheel"))
    ]
    assert bare == [], "say in a comment above each of these why it is a dependency"


def test_numba_is_not_a_dependency():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    every = config["project"]["dependencies"] + [
        r for extra in config["project"]["optional-dependencies"].values() for r in extra
    ]
    assert not [r for r in every if r.lower().startswith(("numba", "llvmlite"))]
