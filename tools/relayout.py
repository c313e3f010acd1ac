"""Move core/'s flat modules into one subpackage per layer, and rewrite every reference.

Run it at the top of a checkout (``python tools/relayout.py``, ``--dry-run`` to see the
plan). It is deterministic and idempotent, so it can be run again on a branch that
still has the old layout (other work merged in) and does nothing on one that has the
new layout:

1. refuses to start while core/ holds a module the tables below do not place
   (add it to :data:`MODULES` and run again: nothing has been changed then);
2. reads every text file git tracks and rewrites, from old to new names:
   ``from``-imports (parsed, so relative imports of moved modules and
   ``from armtree import runtime`` come out right), dotted module names anywhere
   (``armtree.runtime.Run`` in code, strings, monkeypatch targets, docs, templates,
   entry points), and file paths (``core/runtime.py``, ``core/motion/``);
3. ``git mv``-es the files and directories, and creates each layer's ``__init__.py``;
4. lists the new packages in pyproject.toml and moves the new-plugin templates'
   package data with them;
5. re-sorts and formats the Python files it changed with ruff (when installed).

Two old modules share their name with the layer package that replaces them
(``armtree.runtime`` -> ``armtree.runtime.runner``, ``armtree.cli`` ->
``armtree.cli.commandline``). A bare ``armtree.runtime`` is only rewritten while
``core/runtime.py`` still exists, which keeps a second run from touching the new
names. Names that later commits moved between modules are in :data:`SYMBOLS`: an
import of such a name is pointed at its new module once that module defines it and
the old one no longer does, so merged code that still imports it from the old place
is fixed by running the script again.
"""

from __future__ import annotations

import argparse
import ast
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

#: The layers from the bottom up; each may import only the layers below it.
LAYERS = ("errors", "maths", "config", "api", "hooks", "loader", "runtime", "cli")

#: The docstring of each new layer package's ``__init__.py``.
LAYER_DOCS = {
    "maths": (
        "The shared maths: motion (transforms, kinematic models, collision, workspace,\n"
        "trajectories) and perception (marker frames, hand-eye calibration, pose filters).\n"
        "\n"
        "Layer 2 of 8 (docs/architecture.md): imports only :mod:`armtree.errors`."
    ),
    "config": (
        "Configuration: YAML with positions, parameter declarations, hardware profiles and\n"
        "their sections (workcell, calibration, components), files found by name.\n"
        "\n"
        "Layer 3 of 8 (docs/architecture.md): imports only the maths and the errors."
    ),
    "api": (
        "What behaviours and components program against: the rig and its component\n"
        "interfaces, the clock, the behaviour base class, the emulator and measuring-device\n"
        "contracts, camera intrinsics, and the world as a run's outcomes are judged on it.\n"
        "\n"
        "Layer 4 of 8 (docs/architecture.md): imports only config, maths and errors."
    ),
    "hooks": (
        "The plugin contract and its manager: hook specifications, finding, loading and\n"
        "checking plugins, calling hooks, and the built-in py_trees behaviours plugin.\n"
        "\n"
        "Layer 5 of 8 (docs/architecture.md): imports only the api and the layers below."
    ),
    "loader": (
        "Tree files to validated py_trees trees, every error with its file, line and\n"
        "column before anything runs; and the JSON Schema of what it accepts.\n"
        "\n"
        "Layer 6 of 8 (docs/architecture.md): imports only hooks and the layers below."
    ),
    "runtime": (
        "One run of a tree on a rig: the tick loop and its collaborators (clock pacing,\n"
        "interrupts, run log, watchdog, halting, the result).\n"
        "\n"
        "Layer 7 of 8 (docs/architecture.md): imports only the loader and the layers below."
    ),
    "cli": (
        "The command lines: the console scripts (Ctrl-C held from the first import),\n"
        "options and exit codes, the core subcommands, sweeps, benchmarks, the\n"
        "new-plugin scaffold and the generated parts of the docs.\n"
        "\n"
        "Layer 8 of 8 (docs/architecture.md), the top of core: plugins may import it."
    ),
}

#: Old module or package (under ``armtree.``) -> its new name. Packages move whole,
#: with any module another branch added to them.
MODULES = {
    # maths
    "motion": "maths.motion",
    "perception": "maths.perception",
    "hand_eye": "maths.perception.hand_eye",
    # config
    "yamlio": "config.yamlio",
    "resolve": "config.resolve",
    "params": "config.params",
    "constructor_params": "config.constructor_params",
    "profile_include": "config.profile_include",
    "profile_sections": "config.profile_sections",
    "component_config": "config.component_config",
    "calibration": "config.calibration",
    "workcell": "config.workcell",
    # api
    "clock": "api.clock",
    "rig": "api.rig",
    "behaviour": "api.behaviour",
    "emulation": "api.emulation",
    "measuring": "api.measuring",
    "worldview": "api.worldview",
    "imaging": "api.imaging",
    "outcomes": "api.outcomes",
    # hooks (the plugin manager's layer; armtree.plugins is the built-in plugins)
    "hookspecs": "hooks.hookspecs",
    "plugin_manager": "hooks.plugin_manager",
    "plugin_checks": "hooks.plugin_checks",
    "hook_calls": "hooks.hook_calls",
    "builtin_behaviours": "hooks.builtin_behaviours",
    # loader (hardware profiles too: loading one asks the plugins about its components)
    "profile": "loader.profile",
    "tree_loader": "loader.tree_loader",
    "tree": "loader.tree",
    "load_context": "loader.load_context",
    "tree_keys": "loader.tree_keys",
    "tree_params": "loader.tree_params",
    "node_builder": "loader.node_builder",
    "node_params": "loader.node_params",
    "subtree_include": "loader.subtree_include",
    "blackboard_use": "loader.blackboard_use",
    "tree_checks": "loader.tree_checks",
    "schema": "loader.schema",
    # runtime
    "runtime": "runtime.runner",
    "run_start": "runtime.run_start",
    "run_end": "runtime.run_end",
    "run_hooks": "runtime.run_hooks",
    "run_watchdog": "runtime.run_watchdog",
    "runlog": "runtime.runlog",
    "blackboard_log": "runtime.blackboard_log",
    "node_index": "runtime.node_index",
    "status_tracking": "runtime.status_tracking",
    "status_guard": "runtime.status_guard",
    "stall_watch": "runtime.stall_watch",
    "failure_report": "runtime.failure_report",
    "feedback_log": "runtime.feedback_log",
    "pacing": "runtime.pacing",
    "pausing": "runtime.pausing",
    "halting": "runtime.halting",
    "tree_replacement": "runtime.tree_replacement",
    "watchdog": "runtime.watchdog",
    "interrupts": "runtime.interrupts",
    "control": "runtime.control",
    "rig_builder": "runtime.rig_builder",
    "resources": "runtime.resources",
    "display": "runtime.display",
    # cli
    "cli": "cli.commandline",
    "console": "cli.console",
    "builtin_commands": "cli.builtin_commands",
    "bench": "cli.bench",
    "scaffold": "cli.scaffold",
    "sweep": "cli.sweep",
    "docgen": "cli.docgen",
    "hook_reference": "cli.hook_reference",
    "profile_reference": "cli.profile_reference",
}

#: Folders of data (not Python packages) that move with the module using them.
DATA_DIRS = {"templates": "cli/templates"}

#: What core/ holds besides the layers once done.
KEEP_AT_TOP = {"__init__.py", "__init__.pyi", "py.typed", "errors.py", "__pycache__"}

#: Names moved between modules by later commits: (module, name) -> the module that
#: defines it now. Applied to an import of the name from the old module once the old
#: module no longer binds it and the new one defines it.
SYMBOLS: dict[tuple[str, str], str] = {
    ("armtree.hooks.plugin_manager", "did_you_mean"): "armtree.errors",
    ("armtree.loader.profile", "profile_section"): "armtree.config.profile_access",
    ("armtree.loader.profile", "profile_source"): "armtree.config.profile_access",
    ("armtree.loader.profile", "profile_error"): "armtree.config.profile_access",
    ("armtree.loader.node_builder", "node_kind"): "armtree.api.factories",
    ("armtree.loader.node_builder", "construct"): "armtree.api.factories",
    ("armtree.hooks.builtin_behaviours", "LEAF"): "armtree.api.factories",
    ("armtree.hooks.builtin_behaviours", "COMPOSITE"): "armtree.api.factories",
    ("armtree.hooks.builtin_behaviours", "DECORATOR"): "armtree.api.factories",
    ("armtree.loader.profile", "PROFILE_KEYS"): "armtree.config.profile_sections",
    ("armtree.loader.profile", "COMPONENT_SECTIONS"): "armtree.config.profile_sections",
    ("armtree.runtime.watchdog", "DEFAULT_TICK_S"): "armtree.config.profile_sections",
    ("armtree.runtime.watchdog", "MAX_TICK_S"): "armtree.config.profile_sections",
    ("armtree.maths.motion.start_contact", "leaving_run"): "armtree.maths.motion.penetration",
    ("armtree.api.outcomes.expect", "Expectation"): "armtree.api.outcomes.predicates",
    ("armtree.loader.node_builder", "node_name"): "armtree.loader.node_names",
    ("armtree.maths.motion.start_contact", "START_CONTACT_MM"): "armtree.maths.motion.penetration",
}

#: The last part of a dotted name that makes it a file name, not a module's attribute
#: (``armtree.schema.json`` is the shipped schema file).
FILE_SUFFIXES = {"json", "yaml", "yml", "md", "txt", "toml", "png", "html", "py", "csv", "stl"}

#: The files this script must not rewrite: itself and its test (they name old modules).
SELF = {"tools/relayout.py", "tests/test_relayout.py"}

DOTTED = re.compile(r"(?<![\w.])armtree((?:\.[A-Za-z_]\w*)+)")
PATH = re.compile(r"(?<![\w./-])(core|armtree)/(\w+(?:\.\w+)*(?:/\w+(?:\.\w+)*)*/?)")


@dataclass
class Plan:
    """What a run of the script does in one checkout."""

    root: Path
    #: Old modules whose name is also a new layer package, rewritten while the old file exists.
    ambiguous_live: set[str] = field(default_factory=set)
    #: (old path, new path), relative to the root, for every file or folder to move.
    moves: list[tuple[str, str]] = field(default_factory=list)
    #: old path -> new path of every tracked file under a moved path.
    file_moves: dict[str, str] = field(default_factory=dict)
    #: What each core module binds, by its new name (see :func:`index_names`).
    index: dict[str, Names] = field(default_factory=dict)


def run(*args: str, root: Path, check: bool = True) -> str:
    done = subprocess.run(args, cwd=root, capture_output=True, text=True, check=False)
    if check and done.returncode != 0:
        sys.exit(f"{' '.join(args)} failed:\n{done.stdout}{done.stderr}")
    return done.stdout


def old_path(old: str, root: Path) -> str | None:
    """core/ path of an old module or package, when it is still there."""
    if old in PACKAGES:
        return f"core/{old}" if (root / "core" / old / "__init__.py").is_file() else None
    return f"core/{old}.py" if (root / "core" / f"{old}.py").is_file() else None


def new_path(old: str, new: str, is_dir: bool) -> str:
    return f"core/{new.replace('.', '/')}" + ("" if is_dir else ".py")


def plan(root: Path) -> Plan:
    p = Plan(root)
    unknown = sorted(
        path.name
        for path in (root / "core").iterdir()
        if path.name not in KEEP_AT_TOP
        and path.name not in LAYERS
        and path.name.removesuffix(".py") not in MODULES
        and path.name not in DATA_DIRS
        and (path.suffix == ".py" or (path / "__init__.py").is_file())
    )
    if unknown:
        sys.exit(
            "core/ holds modules tools/relayout.py does not place: "
            + ", ".join(unknown)
            + "\nadd each to MODULES (old name -> layer.name) and run it again; nothing changed."
        )
    for old, new in MODULES.items():
        if new.split(".", 1)[0] == old and (root / "core" / f"{old}.py").is_file():
            p.ambiguous_live.add(old)
        src = old_path(old, root)
        if src is None:
            continue
        dst = new_path(old, new, old in PACKAGES)
        if (root / dst).exists():
            sys.exit(f"both {src} and {dst} exist: merge them by hand, then run again")
        p.moves.append((src, dst))
    for old, new in DATA_DIRS.items():
        if (root / "core" / old).is_dir():
            p.moves.append((f"core/{old}", f"core/{new}"))
    tracked = run("git", "ls-files", root=root).splitlines()
    for src, dst in p.moves:
        for path in tracked:
            if path == src:
                p.file_moves[path] = dst
            elif path.startswith(src + "/"):
                p.file_moves[path] = dst + path[len(src) :]
    return p


# --- names -----------------------------------------------------------------------


def map_module(name: str, p: Plan) -> str:
    """The new dotted name of ``armtree.X...`` (unchanged when not moved)."""
    parts = name.split(".")
    if parts[0] != "armtree":
        return name
    for i in range(len(parts), 1, -1):
        old = ".".join(parts[1:i])
        if old in MODULES and (old not in AMBIGUOUS or old in p.ambiguous_live):
            return ".".join(["armtree", MODULES[old], *parts[i:]])
    return name


AMBIGUOUS = {old for old, new in MODULES.items() if new.split(".", 1)[0] == old}


def is_old_module(name: str, p: Plan) -> bool:
    """Whether ``armtree.X`` names a module the table moves (not an attribute)."""
    old = name.removeprefix("armtree.")
    return old in MODULES and (old not in AMBIGUOUS or old in p.ambiguous_live)


def rewrite_dotted(text: str, p: Plan) -> str:
    def one(m: re.Match) -> str:
        parts = m.group(1).lstrip(".").split(".")
        for i in range(len(parts), 0, -1):
            old = ".".join(parts[:i])
            if old in MODULES and (old not in AMBIGUOUS or old in p.ambiguous_live):
                rest = parts[i:]
                if len(rest) == 1 and rest[0] in FILE_SUFFIXES:
                    return m.group(0)
                return ".".join(["armtree", MODULES[old], *rest])
        return m.group(0)

    return DOTTED.sub(one, text)


def rewrite_paths(text: str, p: Plan) -> str:
    def one(m: re.Match) -> str:
        top, rest = m.group(1), m.group(2)
        first = rest.split("/", 1)[0]
        if first.endswith(".py") and first[:-3] in MODULES and first[:-3] not in PACKAGES:
            new = MODULES[first[:-3]].replace(".", "/")
            return f"{top}/{new}.py" + rest[len(first) :]
        if first in DATA_DIRS:
            return f"{top}/{DATA_DIRS[first]}" + rest[len(first) :]
        if first in PACKAGES:
            return f"{top}/{MODULES[first].replace('.', '/')}" + rest[len(first) :]
        return m.group(0)

    return PATH.sub(one, text)


#: Old names that are packages (their folder moves whole).
PACKAGES = {"motion", "perception", "outcomes", "sweep"}


SPECIAL = [
    # the new-plugin templates moved with the scaffold into the cli package
    (re.compile(r'files\("armtree"\)(\s*/\s*"templates")'), r'files("armtree.cli")\1'),
]
#: Applied once the cli package runs as a module (``python -m armtree.cli``, its
#: __main__.py): the old ``-m armtree.cli`` first became ``-m armtree.cli.commandline``.
MAIN_SPECIAL = [
    (re.compile(r'(-m",\s*")armtree\.cli\.commandline(")'), r"\1armtree.cli\2"),
    (re.compile(r"(-m )armtree\.cli\.commandline\b"), r"\1armtree.cli"),
]


#: A one-line ``from armtree... import a, b`` in text that is not parsed as Python:
#: templates, docs, and strings in code (a test writing a plugin file).
FROM_LINE = re.compile(
    r"(?<![\w.])from (armtree(?:\.[A-Za-z_]\w*)+) import ([A-Za-z_]\w*(?:, [A-Za-z_]\w*)*)"
)


def rewrite_from_lines(text: str, p: Plan) -> str:
    """Point such imports at the module that defines each name (as for parsed ones)."""

    def one(m: re.Match) -> str:
        groups: dict[str, list[str]] = {}
        for name in m.group(2).split(", "):
            module, real = origin(m.group(1), name, p.index)
            groups.setdefault(module, []).append(name if real == name else f"{real} as {name}")
        if list(groups) == [m.group(1)]:
            return m.group(0)
        line_start = text.rfind("\n", 0, m.start()) + 1
        indent = text[line_start : m.start()]
        joiner = "\n" + indent if indent.strip() == "" else "; "
        return joiner.join(f"from {mod} import {', '.join(names)}" for mod, names in groups.items())

    return FROM_LINE.sub(one, text)


def rewrite_text(text: str, p: Plan) -> str:
    text = rewrite_dotted(text, p)
    text = rewrite_from_lines(text, p)
    text = rewrite_paths(text, p)
    for pattern, repl in SPECIAL:
        text = pattern.sub(repl, text)
    if (p.root / "core" / "cli" / "__main__.py").is_file():
        for pattern, repl in MAIN_SPECIAL:
            text = pattern.sub(repl, text)
    return text


# --- Python imports ----------------------------------------------------------------


def module_of(path: str) -> tuple[str, bool] | None:
    """The import name of a file under core/ or plugins/, and whether it is a package."""
    parts = Path(path).with_suffix("").parts
    if parts[0] == "core":
        names = ["armtree", *parts[1:]]
    elif parts[0] == "plugins":
        names = ["armtree", "plugins", *parts[1:]]
    else:
        return None
    if names[-1] == "__init__":
        return ".".join(names[:-1]), True
    return ".".join(names), False


def package_of(path: str) -> str | None:
    found = module_of(path)
    if found is None:
        return None
    name, is_package = found
    return name if is_package else name.rpartition(".")[0]


@dataclass
class Names:
    """What a core module binds at its top level: names it defines, names it imports."""

    defined: set[str] = field(default_factory=set)
    #: local name -> (module it comes from, its name there), for unconditional imports
    imported: dict[str, tuple[str, str]] = field(default_factory=dict)


def absolute_base(node: ast.ImportFrom, package: str | None) -> str | None:
    if not node.level:
        return node.module or ""
    if package is None:
        return None
    parts = package.split(".")
    base = ".".join(parts[: len(parts) - node.level + 1])
    return f"{base}.{node.module}" if node.module else base


def bound(node: ast.stmt) -> set[str]:
    """Names a top-level statement binds (not those local to a function or class)."""
    if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
        return {node.name}
    if isinstance(node, ast.Import | ast.ImportFrom):
        return {a.asname or a.name.split(".")[0] for a in node.names}
    found: set[str] = set()
    for child in ast.iter_child_nodes(node):
        if isinstance(child, ast.stmt):
            found |= bound(child)
        elif isinstance(child, ast.excepthandler):
            found |= {name for stmt in child.body for name in bound(stmt)}
        else:
            found |= {
                n.id
                for n in ast.walk(child)
                if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)
            }
    return found


def index_names(sources: dict[str, str], p: Plan) -> dict[str, Names]:
    """New module name -> :class:`Names`, for every core module, from its source."""
    index: dict[str, Names] = {}
    for path, source in sources.items():
        dest = p.file_moves.get(path, path)
        found = module_of(dest)
        if found is None or not dest.startswith("core/"):
            continue
        names = index.setdefault(found[0], Names())
        try:
            body = ast.parse(source).body
        except SyntaxError:
            continue
        for node in body:
            if isinstance(node, ast.ImportFrom):
                base = absolute_base(node, package_of(path))
                for alias in node.names:
                    local = alias.asname or alias.name
                    if base is None or alias.name == "*":
                        names.defined.add(local)
                    elif is_old_module(f"{base}.{alias.name}", p):
                        names.defined.add(local)  # a submodule, not a name to follow
                    else:
                        names.imported[local] = (map_module(base, p), alias.name)
            else:
                names.defined |= bound(node)
    return index


def origin(module: str, name: str, index: dict[str, Names]) -> tuple[str, str]:
    """Where ``from module import name`` really comes from: the module that defines it.

    Followed through core modules that only import the name (re-exports), and through
    :data:`SYMBOLS` for a name that left its module; the public ``armtree`` package
    itself is never looked through.
    """
    seen = set()
    while module != "armtree" and module in index and (module, name) not in seen:
        seen.add((module, name))
        names = index[module]
        if name in names.defined or f"{module}.{name}" in index:
            return module, name
        if name in names.imported:
            module, name = names.imported[name]
            continue
        moved = SYMBOLS.get((module, name))
        if moved and moved in index and name in index[moved].defined:
            return moved, name
        return module, name
    return module, name


def import_replacements(
    source: str, path: str, new_file: str, p: Plan, index: dict[str, Names]
) -> Iterator[tuple[int, int, str]]:
    """(start, end, text) of every ``from``-import that must change."""
    tree = ast.parse(source)
    old_package = package_of(path)
    new_package = package_of(new_file)
    moved = path != new_file
    lines = source.splitlines(keepends=True)
    starts = [0]
    for line in lines:
        starts.append(starts[-1] + len(line))

    def offset(lineno: int, col: int) -> int:
        line = lines[lineno - 1]
        return starts[lineno - 1] + len(line.encode()[:col].decode())

    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom):
            continue
        base = absolute_base(node, old_package)
        if base is None:
            continue
        outside = not base.startswith("armtree") or base.startswith("armtree.plugins")
        if outside and not (node.level and moved):
            continue
        groups: dict[str, list[str]] = {}
        changed = bool(node.level and moved)
        for alias in node.names:
            full = f"{base}.{alias.name}"
            local = alias.asname or alias.name
            if is_old_module(full, p):
                target = map_module(full, p)
                module, _, name = target.rpartition(".")
            else:
                module, name = origin(map_module(base, p), alias.name, index)
            if module != base or name != alias.name:
                changed = True
            groups.setdefault(module, []).append(name if name == local else f"{name} as {local}")
        if not changed:
            continue
        start = offset(node.lineno, node.col_offset)
        end = offset(node.end_lineno, node.end_col_offset)
        line = lines[node.lineno - 1]
        indent = line[: len(line.encode()[: node.col_offset].decode())]
        joiner = "\n" + indent if indent.strip() == "" else "; "
        statements = []
        for module, names in groups.items():
            relative = bool(node.level) and new_package is not None
            if relative and module == new_package:
                head = "from . import"
            elif relative and module.rpartition(".")[0] == new_package:
                head = f"from .{module.rpartition('.')[2]} import"
            else:
                head = f"from {module} import"
            statements.append(f"{head} {', '.join(names)}")
        yield start, end, joiner.join(statements)


def rewrite_python(source: str, path: str, new_file: str, p: Plan, index: dict[str, Names]) -> str:
    try:
        spans = sorted(import_replacements(source, path, new_file, p, index))
    except SyntaxError:
        return rewrite_text(source, p)
    out, last = [], 0
    for start, end, text in spans:
        out.append(rewrite_text(source[last:start], p))
        out.append(text)
        last = end
    out.append(rewrite_text(source[last:], p))
    result = "".join(out)
    if path == "core/__init__.py":
        result = rewrite_lazy_table(result, p)
    return result


def rewrite_lazy_table(source: str, p: Plan) -> str:
    """``armtree/__init__.py``'s table of public names: its submodule names, mapped."""

    def one(m: re.Match) -> str:
        name = map_module(f"armtree.{m.group(2)}", p).removeprefix("armtree.")
        return f"{m.group(1)}{name}{m.group(3)}"

    block = re.search(r"^_LAZY = \{\n(.*?)^\}", source, re.S | re.M)
    if not block:
        return source
    body = re.sub(r'(: ")([\w.]+)(",)', one, block.group(1))
    return source[: block.start(1)] + body + source[block.end(1) :]


# --- pyproject ---------------------------------------------------------------------


def rewrite_pyproject(text: str, p: Plan, root: Path) -> str:
    text = rewrite_text(text, p)
    block = re.search(r"^packages = \[\n(.*?)^\]", text, re.S | re.M)
    if block:
        # the core packages, as found on disk, where the first of them was listed
        on_disk = {
            ".".join(["armtree", *init.parent.relative_to(root / "core").parts])
            for init in (root / "core").rglob("__init__.py")
            if "templates" not in init.parts
        }
        lines = block.group(1).splitlines(keepends=True)
        is_core = [
            bool(re.search(r'"armtree(\.|")', line))
            and not re.search(r'"armtree\.(plugins|trees|hardware)\b', line)
            for line in lines
        ]
        at = is_core.index(True) if True in is_core else 0
        listed = {
            line.strip().strip('",') for line, core in zip(lines, is_core, strict=True) if core
        }
        rest = [line for line, core in zip(lines, is_core, strict=True) if not core]
        core_lines = [f'    "{name}",\n' for name in sorted(on_disk | listed)]
        lines = rest[:at] + core_lines + rest[at:]
        text = text[: block.start(1)] + "".join(lines) + text[block.end(1) :]
    templates = '"templates/new_plugin/*/*.tmpl"'
    if templates in text and (root / "core" / "cli" / "templates").is_dir():
        text = re.sub(
            r'(^"armtree" = \[[^\]\n]*?), ' + re.escape(templates), r"\1", text, flags=re.M
        )
        if '"armtree.cli" = [' not in text:
            text = re.sub(
                r'(^"armtree" = \[[^\n]*\]\n)',
                r'\1"armtree.cli" = [' + templates + "]\n",
                text,
                flags=re.M,
            )
    return text


# --- the run -------------------------------------------------------------------------


def text_of(path: Path) -> str | None:
    data = path.read_bytes()
    if b"\0" in data:
        return None
    try:
        return data.decode()
    except UnicodeDecodeError:
        return None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dry-run", action="store_true", help="print the plan, change nothing")
    parser.add_argument("--no-ruff", action="store_true", help="do not sort and format after")
    args = parser.parse_args(argv)
    root = Path(run("git", "rev-parse", "--show-toplevel", root=Path.cwd()).strip())
    p = plan(root)

    sources: dict[str, str] = {}
    for path in run("git", "ls-files", root=root).splitlines():
        if path in SELF or not (root / path).is_file():
            continue
        source = text_of(root / path)
        if source is not None:
            sources[path] = source
    index = index_names({k: v for k, v in sources.items() if k.endswith(".py")}, p)
    p.index = index
    rewritten: dict[str, str] = {}
    for path, source in sources.items():
        dest = p.file_moves.get(path, path)
        if path.endswith(".py"):
            new = rewrite_python(source, path, dest, p, index)
        elif path == "pyproject.toml":
            new = source  # after the moves, when the new packages are on disk
        else:
            new = rewrite_text(source, p)
        if new != source or dest != path:
            rewritten[path] = new

    if args.dry_run:
        for src, dst in p.moves:
            print(f"git mv {src} {dst}")
        for path in sorted(rewritten):
            print(f"rewrite {p.file_moves.get(path, path)}")
        return 0

    for layer in LAYERS[1:]:
        (root / "core" / layer).mkdir(exist_ok=True)
    for src, dst in p.moves:
        (root / dst).parent.mkdir(parents=True, exist_ok=True)
        run("git", "mv", src, dst, root=root)
    created = []
    for layer, doc in LAYER_DOCS.items():
        init = root / "core" / layer / "__init__.py"
        if not init.exists():
            init.write_text(f'"""{doc}\n"""\n')
            created.append(str(init.relative_to(root)))
    if created:
        run("git", "add", *created, root=root)
    changed_py = []
    for path, text in rewritten.items():
        dest = p.file_moves.get(path, path)
        (root / dest).write_text(text)
        if dest.endswith(".py"):
            changed_py.append(dest)
    pyproject = root / "pyproject.toml"
    before = pyproject.read_text()
    after = rewrite_pyproject(before, p, root)
    if after != before:
        pyproject.write_text(after)
    if changed_py and not args.no_ruff and shutil.which("ruff"):
        run(
            "ruff",
            "check",
            "--select",
            "I",
            "--fix",
            "--quiet",
            *changed_py,
            root=root,
            check=False,
        )
        run("ruff", "format", "--quiet", *changed_py, root=root, check=False)
    print(f"{len(p.moves)} moves, {len(rewritten)} files rewritten")
    return 0


if __name__ == "__main__":
    sys.exit(main())
