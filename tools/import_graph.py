"""Measure armtree's import graph: modules per package, import cycles, the longest chain.

Every import statement counts (module level, inside a function, under TYPE_CHECKING),
as the issue counts them. Run from a checkout: ``python tools/import_graph.py [--json]``.
"""

from __future__ import annotations

import argparse
import ast
import json
import re
from collections import Counter
from pathlib import Path

import networkx as nx

ROOT = Path(__file__).resolve().parent.parent


def module_name(path: Path) -> tuple[str, bool]:
    """The import name of a source file under core/ or plugins/, and whether it is a package."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    prefix = ["armtree"] if parts[0] == "core" else ["armtree", "plugins"]
    is_package = parts[-1] == "__init__"
    names = prefix + parts[1:]
    return ".".join(names[:-1] if is_package else names), is_package


def sources() -> dict[str, tuple[Path, bool]]:
    """Every module of the package: import name -> (file, is a package)."""
    found = {}
    for top in ("core", "plugins"):
        for path in sorted((ROOT / top).rglob("*.py")):
            if "templates" in path.parts:
                continue
            name, is_package = module_name(path)
            found[name] = (path, is_package)
    return found


def _type_only(tree: ast.Module) -> set[int]:
    """ids of the import statements under ``if TYPE_CHECKING:``."""
    return {
        id(n)
        for node in ast.walk(tree)
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
        for n in ast.walk(node)
    }


def imports(type_only_allowed_in: str | None = None) -> list[tuple[str, str, int, str]]:
    """(importer, imported module, line, statement) for every import of an armtree module
    by the package (less the type-only ones of ``type_only_allowed_in``, when given)."""
    modules = sources()
    found = []
    for module, (path, is_package) in modules.items():
        package = module if is_package else module.rsplit(".", 1)[0]
        source = path.read_text()
        lines = source.splitlines()
        tree = ast.parse(source, str(path))
        skip = _type_only(tree) if module == type_only_allowed_in else set()
        for node in ast.walk(tree):
            if id(node) in skip:
                continue
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    parts = package.split(".")
                    base = ".".join(parts[: len(parts) - node.level + 1])
                    base = f"{base}.{node.module}" if node.module else base
                else:
                    base = node.module or ""
                # ``from pkg import sub`` imports the submodule when there is one
                targets = [
                    f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base
                    for a in node.names
                ]
            else:
                continue
            for target in targets:
                while target and target not in modules:
                    target = target.rpartition(".")[0]
                if target and target != module:
                    found.append((module, target, node.lineno, lines[node.lineno - 1].strip()))
    return found


def graph(type_only_allowed_in: str | None = None) -> nx.DiGraph:
    """Module -> module it imports, for every import statement of the package."""
    g = nx.DiGraph()
    g.add_nodes_from(sources())
    g.add_edges_from((a, b) for a, b, _, _ in imports(type_only_allowed_in))
    return g


def package_of(module: str, modules: dict[str, tuple[Path, bool]]) -> str:
    return module if modules[module][1] else module.rsplit(".", 1)[0]


def any_count(top: str) -> int:
    pattern = re.compile(r"\bAny\b")
    return sum(
        len(pattern.findall(line))
        for path in (ROOT / top).rglob("*.py")
        for line in path.read_text().splitlines()
        if not line.lstrip().startswith(("from typing import", "import typing", "#"))
    )


def measure(type_only_allowed_in: str | None = None) -> dict:
    modules = sources()
    g = graph(type_only_allowed_in)
    cycles = [sorted(c) for c in nx.strongly_connected_components(g) if len(c) > 1]
    cycles.sort(key=len, reverse=True)
    dag = nx.condensation(g)
    longest = nx.dag_longest_path(dag)
    chain = [sorted(dag.nodes[n]["members"])[0] for n in longest]
    per_package = Counter(package_of(m, modules) for m in modules)
    return {
        "modules": len(modules),
        "modules_per_package": dict(sorted(per_package.items())),
        "edges": g.number_of_edges(),
        "cycles": len(cycles),
        "cycle_sizes": [len(c) for c in cycles],
        "cycle_members": cycles,
        "longest_chain_length": len(chain),
        "longest_chain": chain,
        "any_core": any_count("core"),
        "any_plugins": any_count("plugins"),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    parser.add_argument(
        "--allow-type-only-in",
        metavar="MODULE",
        help="leave out this module's TYPE_CHECKING imports (armtree.hooks.hookspecs)",
    )
    args = parser.parse_args()
    m = measure(args.allow_type_only_in)
    if args.json:
        print(json.dumps(m, indent=1))
        return
    print(f"modules: {m['modules']}, import edges: {m['edges']}")
    for package, n in m["modules_per_package"].items():
        print(f"  {package}: {n}")
    print(f"import cycles (SCCs of more than one module): {m['cycles']} {m['cycle_sizes']}")
    for members in m["cycle_members"]:
        print("  " + " ".join(members))
    print(f"longest import chain (over the SCC condensation): {m['longest_chain_length']}")
    print("  " + " -> ".join(m["longest_chain"]))
    print(f"Any: core {m['any_core']}, plugins {m['any_plugins']}")


if __name__ == "__main__":
    main()
