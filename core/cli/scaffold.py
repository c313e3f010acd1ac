"""``armtree new-plugin NAME --kind skill|arm|tracker|planner|camera``: a ready plugin package.

The package has a ``pyproject.toml`` with the ``armtree`` entry point, the
plugin module (a documented, working example of its kind: an arm comes with its
kinematics, driver and firmware emulator on a pseudo-terminal), a tree and a
simulated profile that use it, a README, and pytest tests that run the tree on
the simulation and let the simulated world judge it. The templates are in
``armtree/cli/templates/new_plugin/`` (``common/`` and one folder per kind), filled
in with :class:`string.Template` (``${name}``, ``${class_name}``, ...).
"""

from __future__ import annotations

import argparse
import importlib.resources
import keyword
import re
from dataclasses import dataclass, field
from pathlib import Path
from string import Template

from armtree.errors import ConfigError
from armtree.hooks.plugin_checks import installed_version

KINDS = ("skill", "arm", "tracker", "planner", "camera")

#: Profile sections of the rig the demos run on, before a kind puts its own component in.
SIM_CAMERA = """
  type: sim
  mount: eye_to_hand
  width: 640
  height: 480
  intrinsics: {fx: 570.0, fy: 570.0, cx: 320.0, cy: 240.0}
  position: [300, 0, 650]     # on a stand above the table, looking straight down
  look_at: [300, 0, 0]"""
SECTIONS = {
    "arm": " {type: vicra, port: sim, tool: suction}   # armtree's VICRA SCARA, emulated",
    "camera": SIM_CAMERA,
    "tracker": " {type: aruco, dictionary: 4x4_50}",
    "planner": " {type: direct}",
}
#: What every generated test module imports.
TEST_IMPORTS = (
    "import armtree",
    "from armtree.cli.commandline import run_tree_main",
    "from armtree.hooks.plugin_checks import deep_problems",
    "from armtree.hooks.plugin_manager import get_plugin_manager",
)
PICK_AND_PLACE_CHECK = "world_moved.tmpl"


@dataclass(frozen=True)
class KindSpec:
    """What a kind adds to the common package: modules, tree, profile section, tests."""

    registry_kind: str
    summary: str
    modules: tuple[str, ...]
    files: str
    #: Imports of its tests from other distributions, and from the plugin's own package.
    imports: tuple[str, ...]
    own_imports: tuple[str, ...] = ()
    section: tuple[str, str] | None = None
    tree: str = "common/pick_and_place_tree.yaml.tmpl"
    world_check: str = f"common/{PICK_AND_PLACE_CHECK}"
    tree_summary: str = (
        "armtree's pick-and-place tree run on the profile below, which uses the plugin"
    )
    profile_summary: str = "armtree's emulated VICRA arm, a camera on a stand, a ducky to move"
    extra: dict[str, str] = field(default_factory=dict)


SPECS: dict[str, KindSpec] = {
    "skill": KindSpec(
        registry_kind="behaviour",
        summary="${title}: an armtree skill that finds a tag with the camera, hovers the tool above "
        "it and picks it up with the rig's tool.",
        modules=("plugin.py",),
        files="- `src/${package}/plugin.py`: the skill (a behaviour) and its registration.",
        imports=("import numpy as np", "from armtree.runtime.runlog import read_log"),
        tree="skill/tree.yaml.tmpl",
        world_check="skill/world_check.tmpl",
        tree_summary="the skill picks up the ducky it finds with the camera, then the arm goes home",
    ),
    "arm": KindSpec(
        registry_kind="arm",
        summary="${title}: an armtree arm (a SCARA with a suction cup): kinematics, serial driver and "
        "firmware emulator.",
        modules=("plugin.py", "kinematics.py", "driver.py", "emulator.py"),
        files=(
            "- `src/${package}/plugin.py`: the arm's factory and its registration.\n"
            "- `src/${package}/kinematics.py`: joints, limits, a workspace constraint, link frames,\n"
            "  link boxes and inverse kinematics (what planners, `armtree workspace` and the sim read).\n"
            "- `src/${package}/driver.py`: the serial driver (pyserial, its own I/O thread).\n"
            "- `src/${package}/emulator.py`: the firmware, byte for byte, on a pseudo-terminal\n"
            "  (`port: sim`; `armtree emulate ${name}` serves it to any serial tool)."
        ),
        imports=(
            "import numpy as np",
            "import serial",
            "from hypothesis import given, settings",
            "from hypothesis import strategies as st",
            "from armtree.api.clock import WallClock",
            "from armtree.maths.motion.workspace import ArmWorkspace",
        ),
        own_imports=("from ${package}.plugin import emulator, model",),
        section=("arm", " {type: ${name}, port: sim}   # sim: the firmware emulator on a pty"),
        profile_summary="this arm on `port: sim` (its emulator), a camera on a stand, a ducky to move",
    ),
    "tracker": KindSpec(
        registry_kind="tracker",
        summary="${title}: an armtree marker tracker (ArUco with OpenCV, edge-fitted corners, PnP poses).",
        modules=("plugin.py",),
        files="- `src/${package}/plugin.py`: the tracker and its registration.",
        imports=(
            "import cv2",
            "import numpy as np",
            "import pytest",
            "from armtree.api.rig import Frame, TagSpec",
        ),
        own_imports=("from ${package}.plugin import ${class_name}Tracker",),
        section=("tracker", " {type: ${name}, dictionary: 4x4_50}"),
    ),
    "planner": KindSpec(
        registry_kind="planner",
        summary="${title}: an armtree motion planner (straight, or over at a travel height).",
        modules=("plugin.py",),
        files="- `src/${package}/plugin.py`: the planner and its registration.",
        imports=(
            "import numpy as np",
            "import pytest",
            "from armtree.errors import PlanningError",
            "from armtree.runtime.rig_builder import make_scene",
        ),
        own_imports=("from ${package}.plugin import ${name}_planner",),
        section=("planner", " {type: ${name}, travel_z_mm: 120}"),
    ),
    "camera": KindSpec(
        registry_kind="camera",
        summary="${title}: an armtree camera (an OpenCV device, or the simulation) with CLAHE "
        "contrast equalisation.",
        modules=("plugin.py",),
        files="- `src/${package}/plugin.py`: the camera and its registration.",
        imports=(
            "import cv2",
            "import numpy as np",
            "from armtree.api.clock import VirtualClock",
            "from armtree.api.rig import RigContext",
        ),
        own_imports=("from ${package}.plugin import ${class_name}Camera, ${name}_camera",),
        section=(
            "camera",
            SIM_CAMERA.replace(
                "type: sim", "type: ${name}\n  device: sim         # or 0, /dev/video0"
            ),
        ),
    ),
}


def plugin_names(name: str) -> dict[str, str]:
    """The names a plugin called ``name`` goes by; ConfigError for a name that cannot be one."""
    snake = name.strip().replace("-", "_").lower()
    if not re.fullmatch(r"[a-z][a-z0-9_]*", snake) or keyword.iskeyword(snake) or len(snake) > 40:
        raise ConfigError(
            f"new-plugin: {name!r} is not a plugin name: use letters, digits and _ "
            "(starting with a letter, at most 40), e.g. my_gripper"
        )
    words = [w for w in snake.split("_") if w]
    version = installed_version().split(".")
    major, minor = int(version[0]), int(version[1]) if len(version) > 1 else 0
    supported = (
        f">={major}.{minor},<{major}.{minor + 1}" if major == 0 else f">={major},<{major + 1}"
    )
    return {
        "name": snake,
        "title": " ".join(words).capitalize(),
        "class_name": "".join(w.capitalize() for w in words),
        "package": f"armtree_{snake}",
        "dist": f"armtree-{snake.replace('_', '-')}",
        "dist_file": f"armtree_{snake}",
        "armtree_requires": supported,
    }


def _import_block(spec: KindSpec) -> str:
    """The test module's imports, grouped and sorted as isort (and ruff) would."""
    third = sorted(set(TEST_IMPORTS) | set(spec.imports), key=_import_key)
    block = "\n".join(third)
    if spec.own_imports:
        block += "\n\n" + "\n".join(sorted(spec.own_imports, key=_import_key))
    return block


def _import_key(line: str) -> tuple[bool, str, str]:
    return line.startswith("from "), line.split()[1], line


def _template(path: str) -> str:
    root = importlib.resources.files("armtree.cli") / "templates" / "new_plugin"
    return (root / path).read_text(encoding="utf-8")


def render_package(name: str, kind: str) -> dict[str, str]:
    """``{relative path: text}`` of every file of the package (nothing written)."""
    if kind not in SPECS:
        raise ConfigError(f"new-plugin: --kind must be one of {', '.join(KINDS)}, not {kind!r}")
    names = plugin_names(name)
    spec = SPECS[kind]

    def fill(text: str, **more: str) -> str:
        return Template(text).substitute({**names, **more})

    sections = dict(SECTIONS)
    if spec.section is not None:
        sections[spec.section[0]] = fill(spec.section[1])
    values = {
        "kind": kind,
        "registry_kind": spec.registry_kind,
        "summary": fill(spec.summary),
        "files": fill(spec.files),
        "tree_summary": spec.tree_summary,
        "profile_summary": spec.profile_summary,
        **sections,
        "profile_why": f"the demo tree of the {kind} plugin {names['name']} runs here.",
        "profile_description": fill(spec.summary).split(":")[0]
        + " demo rig on the built-in simulation.",
        "tree_why": f"The demo of the {kind} plugin {names['name']}: armtree's skills on a rig that uses it.",
        "tree_using": f"on a rig whose {spec.registry_kind} is {names['name']}",
    }
    tests = _template(f"{kind}/tests.py.tmpl")
    values["imports"] = fill(_import_block(spec))
    values["world_check"] = fill(_template(spec.world_check), **values).rstrip("\n")
    values["tests"] = fill(tests, **values).rstrip("\n")
    package = f"src/{names['package']}"
    files = {
        "pyproject.toml": "common/pyproject.toml.tmpl",
        "README.md": "common/README.md.tmpl",
        ".gitignore": "common/gitignore.tmpl",
        f"{package}/__init__.py": "common/init.py.tmpl",
        f"trees/{names['name']}_demo.yaml": spec.tree,
        f"hardware/sim_{names['name']}.yaml": "common/profile.yaml.tmpl",
        f"tests/test_{names['name']}.py": "common/test.py.tmpl",
        **{f"{package}/{module}": f"{kind}/{module}.tmpl" for module in spec.modules},
    }
    return {path: fill(_template(template), **values) for path, template in files.items()}


def write_package(name: str, kind: str, parent: Path, manager: object = None) -> Path:
    """Write the package into ``parent/<distribution>``; ConfigError when that exists.

    With ``manager``, a name its registry already has for this kind is refused
    (the two plugins could not be loaded together).
    """
    names = plugin_names(name)
    spec = SPECS.get(kind)
    registry = getattr(manager, "registry", None)
    if (
        spec is not None
        and registry is not None
        and registry.has(spec.registry_kind, names["name"])
    ):
        owner = registry.get(spec.registry_kind, names["name"]).plugin
        raise ConfigError(
            f"new-plugin: {spec.registry_kind} {names['name']!r} already exists (plugin {owner!r}); "
            "choose another name"
        )
    files = render_package(name, kind)
    root = parent / names["dist"]
    if root.exists() and any(root.iterdir()):
        raise ConfigError(
            f"new-plugin: {root} already exists and is not empty; choose another --dir or name",
            file=str(root),
        )
    try:
        for relative, text in files.items():
            path = root / relative
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise ConfigError(
            f"new-plugin: cannot write {root}: {exc.strerror or exc}", file=str(root)
        ) from None
    return root


class NewPluginCommand:
    """``armtree new-plugin NAME --kind KIND [--dir D]``: write a ready plugin package."""

    help = "write a ready plugin package: --kind skill, arm, tracker, planner or camera"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add NAME, --kind and --dir."""
        parser.add_argument("name", metavar="NAME", help="the plugin's name, e.g. my_gripper")
        parser.add_argument("--kind", required=True, choices=KINDS, help="what the plugin provides")
        parser.add_argument(
            "--dir",
            default=".",
            metavar="D",
            help="the folder to create the package in (default: here); it goes in D/armtree-NAME",
        )

    def run(self, args: argparse.Namespace) -> int:
        """Write the package and say what to do next."""
        root = write_package(args.name, args.kind, Path(args.dir), getattr(args, "manager", None))
        names = plugin_names(args.name)
        print(f"wrote {root}/ ({args.kind} plugin {names['name']}):")
        for path in sorted(p for p in root.rglob("*") if p.is_file()):
            print(f"  {path.relative_to(root)}")
        print(
            f"next: cd {root} && pip install -e '.[test]' && python -m pytest && "
            f"run-tree trees/{names['name']}_demo.yaml"
        )
        return 0


__all__ = ["KINDS", "NewPluginCommand", "plugin_names", "render_package", "write_package"]
