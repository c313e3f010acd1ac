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
