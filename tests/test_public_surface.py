"""One public surface: ``armtree/__init__.py`` names what is public, and nothing else is
reached through it; its stub tells type checkers the same names; no module elsewhere
re-exports names "as before" or resolves attributes on demand."""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import armtree

ROOT = Path(__file__).resolve().parent.parent


def _stub_names() -> set[str]:
    tree = ast.parse((ROOT / "core" / "__init__.pyi").read_text())
    return {
        alias.asname or alias.name
        for node in tree.body
        if isinstance(node, ast.ImportFrom)
        for alias in node.names
    }


def test_the_table_the_stub_and_all_name_the_same_public_names():
    assert set(armtree._PUBLIC) == set(armtree.__all__) == _stub_names()


def test_each_public_name_is_the_object_its_layer_defines():
    for name, module in armtree._PUBLIC.items():
        assert getattr(armtree, name) is getattr(importlib.import_module(module), name), name


def test_a_submodule_is_not_an_attribute_until_imported():
    code = (
        "import armtree\n"
        "try:\n    armtree.loader\nexcept AttributeError as e:\n    print('refused', e)\n"
        "print(armtree.ConfigError.__module__)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    )
    assert done.stdout.splitlines() == [
        "refused module 'armtree' has no attribute 'loader'",
        "armtree.errors",
    ]


def _modules() -> list[Path]:
    return [
        p
        for top in ("core", "plugins")
        for p in sorted((ROOT / top).rglob("*.py"))
        if "templates" not in p.parts
    ]


def test_no_other_module_resolves_attributes_on_demand():
    found = [
        str(path.relative_to(ROOT))
        for path in _modules()
        for node in ast.parse(path.read_text()).body
        if isinstance(node, ast.FunctionDef) and node.name == "__getattr__"
    ]
    assert found == ["core/__init__.py"]


def test_no_module_re_exports_a_name_it_imports():
    # ``from x import name as name`` and ``__all__`` listing imported names are the
    # re-export idioms; a name is imported from the module that defines it instead.
    found = []
    for path in _modules():
        tree = ast.parse(path.read_text())
        imported = set()
        for node in tree.body:
            if isinstance(node, ast.ImportFrom):
                for alias in node.names:
                    imported.add(alias.asname or alias.name)
                    if alias.asname == alias.name:
                        found.append(f"{path.relative_to(ROOT)}: {alias.name} as {alias.name}")
        for node in tree.body:
            if (
                isinstance(node, ast.Assign)
                and any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets)
                and path.name != "__init__.py"
            ):
                names = {e.value for e in node.value.elts if isinstance(e, ast.Constant)}
                found += [f"{path.relative_to(ROOT)}: __all__ {n}" for n in names & imported]
    assert found == []
