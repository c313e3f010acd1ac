"""The layers of docs/architecture.md, enforced on every import statement of the package
(module level or inside a function): core never imports a plugin, a skill never imports
an arm, camera, tracker or planner, the shared maths imports no framework, and the plugin
packages do not import each other (the sim takes its marker images and the marker
families' rules from the trackers)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
#: Plugin packages that may import another plugin package, and which modules of it.
#: Calibration trees are made of skills (their behaviours are ArmSkills that move and look),
#: and ``armtree calibrate camera`` keeps the trackers' board calibration and image inputs.
ALLOWED_ACROSS = {
    ("sim", "armtree.plugins.trackers.markers"),
    ("sim", "armtree.plugins.trackers.families"),
    ("calibration", "armtree.plugins.skills."),
    ("calibration", "armtree.plugins.trackers.calibration"),
    ("calibration", "armtree.plugins.trackers.commands"),
    ("calibration", "armtree.plugins.trackers.inputs"),
    ("calibration", "armtree.plugins.trackers.preprocess"),
}
#: Framework modules the shared maths may use besides its own: the error types, and the
#: profile the collision scene is built from (for positioned errors).
MATHS_MAY_USE = ("armtree.errors", "armtree.loader.profile")


def _module_name(path: Path) -> tuple[str, bool]:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    prefix = ["armtree"] if parts[0] == "core" else ["armtree", "plugins"]
    is_package = parts[-1] == "__init__"
    names = prefix + parts[1:]
    return ".".join(names[:-1] if is_package else names), is_package


def _imports() -> list[tuple[str, str, int]]:
    """(importing module, imported armtree module or name, line) for every import."""
    found = []
    for top in ("core", "plugins"):
        for path in sorted((ROOT / top).rglob("*.py")):
            if "templates" in path.parts:
                continue  # new-plugin templates are text for other packages
            module, is_package = _module_name(path)
            package = module if is_package else module.rsplit(".", 1)[0]
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, ast.Import):
                    names = [alias.name for alias in node.names]
                elif isinstance(node, ast.ImportFrom):
                    if node.level:
                        parts = package.split(".")
                        base = ".".join(parts[: len(parts) - node.level + 1])
                        base = f"{base}.{node.module}" if node.module else base
                    else:
                        base = node.module or ""
                    names = [f"{base}.{alias.name}" for alias in node.names]
                else:
                    continue
                found += [(module, n, node.lineno) for n in names if n.startswith("armtree.")]
    return found


IMPORTS = _imports()


def _kind(module: str) -> str | None:
    parts = module.split(".")
    return parts[2] if len(parts) > 2 and parts[1] == "plugins" else None


def _broken(rule) -> list[str]:
    return [f"{src}:{line} imports {dst}" for src, dst, line in IMPORTS if rule(src, dst)]


def core_imports_a_plugin(src: str, dst: str) -> bool:
    return _kind(src) is None and dst.startswith("armtree.plugins.")


def skill_imports_a_component(src: str, dst: str) -> bool:
    return _kind(src) == "skills" and _kind(dst) in (
        "arms",
        "cameras",
        "trackers",
        "planners",
        "sim",
    )


def maths_imports_the_framework(src: str, dst: str) -> bool:
    maths = ("armtree.maths.motion.", "armtree.maths.perception.")
    return src.startswith(maths) and not dst.startswith(maths + MATHS_MAY_USE)


def plugins_cross(src: str, dst: str) -> bool:
    a, b = _kind(src), _kind(dst)
    if a is None or b is None or a == b:
        return False
    return not any(a == kind and dst.startswith(allowed) for kind, allowed in ALLOWED_ACROSS)


RULES = [
    core_imports_a_plugin,
    skill_imports_a_component,
    maths_imports_the_framework,
    plugins_cross,
]


def test_the_walk_sees_the_package():
    sources = {src for src, _, _ in IMPORTS}
    assert {
        "armtree.runtime.runner",
        "armtree.maths.motion.kinematics",
        "armtree.plugins.skills.search",
    } <= sources
    # a function-level import is seen too (rig_builder's plugin-free lazy imports, for one)
    assert len(IMPORTS) > 500


@pytest.mark.parametrize("rule", RULES, ids=lambda r: r.__name__)
def test_no_import_breaks_a_rule(rule):
    assert _broken(rule) == []


@pytest.mark.parametrize(
    ("rule", "src", "dst"),
    [
        (core_imports_a_plugin, "armtree.runtime.runner", "armtree.plugins.sim.world.World"),
        (skill_imports_a_component, "armtree.plugins.skills.search", "armtree.plugins.arms.plugin"),
        (
            maths_imports_the_framework,
            "armtree.maths.motion.workspace",
            "armtree.runtime.runner.Run",
        ),
        (plugins_cross, "armtree.plugins.cameras.base", "armtree.plugins.trackers.common.x"),
        (plugins_cross, "armtree.plugins.sim.world", "armtree.plugins.trackers.aruco.x"),
    ],
)
def test_each_rule_catches_what_it_forbids(rule, src, dst):
    assert rule(src, dst)
    assert not rule("armtree.plugins.sim.markers", "armtree.plugins.trackers.markers.marker_square")
