"""The layers of docs/architecture.md, enforced on every import statement of the package
(module level, inside a function, under TYPE_CHECKING) by the import-linter contracts in
pyproject.toml: core's layers import only the layers below them, core never imports a
plugin, the plugin packages do not import each other (the sim takes its marker images
from the trackers; calibration uses the trackers' calibration), and no
package's modules or subpackages import each other in a circle.

grimp, which import-linter reads packages with, finds a package's modules in its folder,
and armtree.plugins lives in plugins/, not in core/; so the graph is built here from
the source files (every import statement, as grimp counts them) and handed to
import-linter's own contract checks. Run ``python -m pytest tests/test_import_rules.py``
rather than ``lint-imports``.
"""

from __future__ import annotations

import ast
import importlib.util
import tomllib
from pathlib import Path

import grimp
import pytest
from importlinter import configuration
from importlinter.application import use_cases
from importlinter.application.app_config import settings
from importlinter.application.ports.building import GraphBuilder

ROOT = Path(__file__).resolve().parent.parent
CONFIG = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
#: The one module whose type-only imports may reach up a layer: the hook specifications
#: name the types hooks are called with.
TYPE_ONLY_IMPORTS_ALLOWED_IN = "armtree.hooks.hookspecs"


def _import_graph_tool():
    spec = importlib.util.spec_from_file_location(
        "import_graph", ROOT / "tools" / "import_graph.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_TOOL = _import_graph_tool()
SOURCES = _TOOL.sources()
#: Every import statement of the package, as tools/import_graph.py reads them.
IMPORTS = _TOOL.imports()


def _graph(extra: tuple[tuple[str, str], ...] = ()) -> grimp.ImportGraph:
    graph = grimp.ImportGraph()
    for module in SOURCES:
        graph.add_module(module)
    for importer, imported, line, text in IMPORTS:
        graph.add_import(importer=importer, imported=imported, line_number=line, line_contents=text)
    for importer, imported in extra:
        graph.add_import(importer=importer, imported=imported, line_number=1, line_contents="")
    return graph


class _Sources(GraphBuilder):
    """Hands import-linter the graph of every import statement in core/ and plugins/."""

    def __init__(self, extra: tuple[tuple[str, str], ...] = ()) -> None:
        self.extra = extra

    def build(self, root_package_names, cache_dir, *args, **kwargs) -> grimp.ImportGraph:
        """The same graph whatever the options: every import counts."""
        return _graph(self.extra)


def _kept(extra: tuple[tuple[str, str], ...] = (), contract: str | None = None) -> bool:
    """Whether import-linter finds the contracts (or one of them) kept; it prints its report."""
    configuration.configure()
    settings.configure(GRAPH_BUILDER=_Sources(extra))
    return use_cases.lint_imports(
        config_filename=str(ROOT / "pyproject.toml"),
        limit_to_contracts=(contract,) if contract else (),
        cache_dir=None,
        no_logo=True,
    )


def test_the_walk_sees_the_package():
    sources = {src for src, _, _, _ in IMPORTS}
    assert {
        "armtree.runtime.runner",
        "armtree.maths.motion.kinematics",
        "armtree.plugins.skills.search",
    } <= sources
    assert len(IMPORTS) > 500
    # a function-level import is seen too (the command line loads the run path lazily)
    assert ("armtree.cli.commandline", "armtree.cli.run_command") in {
        (a, b) for a, b, _, _ in IMPORTS
    }


def test_every_contract_is_kept():
    assert _kept(), "import-linter's report above names each broken contract and its imports"


@pytest.mark.parametrize(
    ("importer", "imported", "contract"),
    [
        ("armtree.runtime.runner", "armtree.plugins.sim.world", "layers"),  # core -> a plugin
        ("armtree.maths.motion.workspace", "armtree.runtime.runner", "layers"),
        ("armtree.config.workcell", "armtree.loader.profile", "layers"),
        ("armtree.plugins.skills.search", "armtree.plugins.arms.plugin", "plugins"),
        ("armtree.plugins.cameras.base", "armtree.plugins.trackers.common", "plugins"),
        ("armtree.plugins.sim.world", "armtree.plugins.trackers.aruco", "plugins"),
        ("armtree.errors", "armtree.maths.motion.geometry", "acyclic"),
        ("armtree.runtime.pacing", "armtree.runtime.runner", "acyclic"),
    ],
)
def test_each_contract_catches_what_it_forbids(importer, imported, contract):
    assert not _kept(((importer, imported),), contract)


def test_the_plugin_contract_names_every_plugin_package():
    kinds = {f"armtree.plugins.{p.parent.name}" for p in (ROOT / "plugins").glob("*/__init__.py")}
    (independence,) = (c for c in CONFIG["contracts"] if c["id"] == "plugins")
    assert set(independence["modules"]) == kinds


#: Plugin modules with a type-only import of their own package: the monitor's replay names
#: the recording and client types of modules that load mcap and aiohttp, which the
#: plugin loads only when a replay is served.
NOT_YET = {"armtree.plugins.monitor.replay"}


def test_type_only_imports_are_only_where_hookspecs_need_types():
    """``if TYPE_CHECKING:`` imports armtree modules in the hook specifications alone, and
    the layers' exemptions are exactly the upward imports it makes."""
    guarded = []
    for module, (path, _) in SOURCES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                imports = [n for n in ast.walk(node) if isinstance(n, ast.ImportFrom)]
                if any(n.level or (n.module or "").startswith("armtree") for n in imports):
                    guarded.append(module)
    assert set(guarded) == {TYPE_ONLY_IMPORTS_ALLOWED_IN, *NOT_YET}
    (layers,) = (c for c in CONFIG["contracts"] if c["id"] == "layers")
    assert {i.split(" -> ")[0] for i in layers["ignore_imports"]} == {TYPE_ONLY_IMPORTS_ALLOWED_IN}
