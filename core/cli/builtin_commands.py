"""Built-in plugin: the core ``armtree`` subcommands (check, show, plugins, schema, hooks, new-plugin).

Each command has ``help``, ``configure(parser)`` and ``run(args) -> int``. The CLI
hands over its plugin manager as ``args.manager`` (``--plugin`` and ``-p no:NAME``
applied); without one the process-wide manager is used. Invalid input raises
:class:`armtree.ConfigError`, which the CLI prints as ``FILE:LINE:COL: message``
and turns into exit code 2.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import py_trees

from armtree.api.output_paths import output_file
from armtree.errors import ConfigError
from armtree.hooks.hookspecs import hookimpl
from armtree.hooks.plugin_checks import Problem, deep_problems, installed_version
from armtree.hooks.plugin_manager import KINDS, PluginManager, get_plugin_manager
from armtree.loader.schema import build_schema
from armtree.loader.tree import Tree
from armtree.loader.tree_loader import load_tree

from .hook_reference import HooksCommand
from .options import add_tree_arguments
from .scaffold import NewPluginCommand


def _manager(args: argparse.Namespace) -> PluginManager:
    manager = getattr(args, "manager", None)
    if manager is not None:
        return manager
    return get_plugin_manager(getattr(args, "plugin", None) or ())


def _load(args: argparse.Namespace) -> Tree:
    return load_tree(
        args.tree, rig=args.rig, overrides=args.overrides or (), manager=_manager(args)
    )


class Check:
    """``armtree check TREE``: validate a tree and its profile without running anything."""

    help = "validate a tree and its hardware profile (exit 0 if valid, 2 if not)"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add TREE, --rig and --set."""
        add_tree_arguments(parser)

    def run(self, args: argparse.Namespace) -> int:
        """Load and validate; print a one-line summary. Raises ConfigError when invalid."""
        tree = _load(args)
        if tree.profile is None:
            _refuse_rigless(tree)
        rig = f" on {tree.profile.name}" if tree.profile is not None else " (no rig)"
        print(f"ok: {tree.name}: {len(tree.nodes)} nodes at {tree.tick_hz:g} Hz{rig}")
        # Checking imports the plugin code a tree, its profile or --plugin names: say which.
        loaded = list(dict.fromkeys([*tree.plugins, *getattr(tree.profile, "plugins", [])]))
        if loaded:
            print("imported plugin code: " + ", ".join(loaded))
        return 0


#: Resources a behaviour claims that only a rig with an arm has.
ARM_RESOURCES = frozenset({"arm", "tool", "head"})


def rig_needs(behaviour: py_trees.behaviour.Behaviour) -> tuple[str, ...]:
    """The rig components a behaviour needs: its ``NEEDS``, and an arm for the resources it claims."""
    needs = list(getattr(behaviour, "NEEDS", ()) or ())
    if ARM_RESOURCES & set(getattr(behaviour, "RESOURCES", ()) or ()) and "arm" not in needs:
        needs.insert(0, "arm")
    return tuple(needs)


def _article(part: str) -> str:
    return f"an {part}" if part[:1] in "aeiou" else f"a {part}"


def _refuse_rigless(tree: Tree) -> None:
    """ConfigError at every node that needs a rig component, for a tree loaded without a rig."""
    errors = []
    for behaviour in tree.root.iterate():
        needs = rig_needs(behaviour)
        if not needs:
            continue
        info = tree.nodes.get(behaviour.id)
        where = info.mark if info is not None else None
        what = info.type if info is not None else behaviour.name
        errors.append(
            ConfigError(
                f"{what} needs a rig with {' and '.join(_article(n) for n in needs)}, but the "
                "tree names none: "
                "add 'rig: PROFILE' to the tree or give --rig PROFILE (e.g. --rig sim_dobot)",
                file=where.file if where else str(tree.source),
                line=where.line if where else None,
                column=where.column if where else None,
            )
        )
    if errors:
        raise ConfigError(
            errors[0].message, errors[0].file, errors[0].line, errors[0].column, errors
        )


class Show:
    """``armtree show TREE``: draw a tree as text, Graphviz dot or a PNG image."""

    help = "draw a tree: --format ascii (default), dot or png"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add TREE, --rig, --set, --format and -o."""
        add_tree_arguments(parser)
        parser.add_argument("--format", choices=("ascii", "dot", "png"), default="ascii")
        parser.add_argument(
            "-o",
            "--output",
            metavar="FILE",
            help="write here (png default: the TREE argument's file name, .png, in this folder)",
        )

    def run(self, args: argparse.Namespace) -> int:
        """Draw the tree; text formats go to stdout unless -o is given."""
        tree = _load(args)
        if args.format == "png":
            # Named from the command line, in the working folder: never from the tree's
            # own `tree:` text, which could be a path anywhere.
            out = output_file(args.output or f"{Path(args.tree).stem or 'tree'}.png", "-o")
            render_png(tree, out)
            print(f"wrote {out}")
            return 0
        text = ascii_text(tree) if args.format == "ascii" else dot_text(tree)
        if args.output is not None:
            output_file(args.output, "-o").write_text(text)
            print(f"wrote {args.output}")
        else:
            sys.stdout.write(text)
        return 0


def ascii_text(tree: Tree) -> str:
    """py_trees' ASCII drawing of the tree (composite symbols, node names)."""
    return py_trees.display.ascii_tree(tree.root)


def dot_text(tree: Tree) -> str:
    """The tree as Graphviz dot source (py_trees' styling)."""
    return py_trees.display.dot_tree(tree.root).to_string()


def render_png(tree: Tree, out: Path) -> None:
    """Render the tree to ``out``: Graphviz when its ``dot`` program is installed, else matplotlib."""
    dot = shutil.which("dot")
    if dot is not None:
        with tempfile.NamedTemporaryFile("w", suffix=".dot", delete=False) as handle:
            handle.write(dot_text(tree))
        try:
            subprocess.run([dot, "-Tpng", "-o", str(out), handle.name], check=True, timeout=60)
        finally:
            Path(handle.name).unlink(missing_ok=True)
        return
    _render_with_matplotlib(tree, out)


#: Face colours by node kind, close to py_trees' dot styling.
_COLOURS = {
    "sequence": "#ff9900",
    "selector": "#00ffff",
    "parallel": "#ffd700",
    "decorator": "#dddddd",
    "leaf": "#ffffff",
}


def _render_with_matplotlib(tree: Tree, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    positions: dict[Any, tuple[float, int]] = {}
    next_leaf = [0.0]

    def place(node: py_trees.behaviour.Behaviour, depth: int) -> float:
        if not node.children:
            x = next_leaf[0]
            next_leaf[0] += 1.0
        else:
            xs = [place(child, depth + 1) for child in node.children]
            x = (xs[0] + xs[-1]) / 2
        positions[node.id] = (x, depth)
        return x

    place(tree.root, 0)
    depth = max(d for _, d in positions.values()) + 1
    width = max(next_leaf[0], 1.0)
    fig, ax = plt.subplots(figsize=(max(4.0, 1.9 * width), max(2.0, 1.1 * depth)))
    for node in tree.root.iterate():
        x, d = positions[node.id]
        for child in node.children:
            cx, cd = positions[child.id]
            ax.plot([x, cx], [-d, -cd], color="#555555", linewidth=0.8, zorder=1)
    for node in tree.root.iterate():
        x, d = positions[node.id]
        info = tree.info(node)
        ntype = info.type if info else type(node).__name__
        if isinstance(node, py_trees.composites.Parallel):
            colour = _COLOURS["parallel"]
        elif isinstance(node, py_trees.composites.Selector):
            colour = _COLOURS["selector"]
        elif isinstance(node, py_trees.composites.Sequence):
            colour = _COLOURS["sequence"]
        elif isinstance(node, py_trees.decorators.Decorator):
            colour = _COLOURS["decorator"]
        else:
            colour = _COLOURS["leaf"]
        label = node.name if node.name == ntype else f"{node.name}\n({ntype})"
        ax.text(
            x,
            -d,
            label,
            ha="center",
            va="center",
            fontsize=8,
            zorder=2,
            bbox={"boxstyle": "round,pad=0.3", "facecolor": colour, "edgecolor": "#333333"},
        )
    ax.set_xlim(-0.7, width - 0.3)
    ax.set_ylim(-depth + 0.4, 0.6)
    ax.set_title(tree.name)
    ax.axis("off")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


class Plugins:
    """``armtree plugins``: every registered component, its plugin and its parameters.

    ``--check`` runs every check on them instead: the interface checks made when
    the registry is built (refusing a component that does not fit), then the deep
    ones (an arm's kinematic model built and checked, behaviours built with their
    defaults); exit 0 when all pass, 2 otherwise.
    """

    help = "list every registered component (kind, name, plugin, description, parameters)"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add --kind to filter and --check."""
        parser.add_argument(
            "--kind",
            choices=tuple(KINDS),
            help="list only this kind",
        )
        parser.add_argument(
            "--check",
            action="store_true",
            help="check every component against its interface (exit 2 on a problem)",
        )

    def run(self, args: argparse.Namespace) -> int:
        """Print a table of the registry, or with --check the checks' verdicts."""
        if args.check:
            return self.check(args)
        from rich.console import Console
        from rich.markup import escape
        from rich.table import Table

        registry = _manager(args).registry
        table = Table(title="armtree components", show_lines=False)
        for column in ("Kind", "Name", "Plugin", "Description", "Parameters"):
            table.add_column(column, overflow="fold")
        for component in registry.all():
            if args.kind and component.kind != args.kind:
                continue
            plugin = component.plugin
            if component.distribution and component.distribution != "armtree":
                plugin = f"{plugin} ({component.distribution})"
            cells = (
                component.kind,
                component.name,
                plugin,
                component.summary,
                "\n".join(p.describe() for p in component.params),
            )
            # units are written [mm], which rich would take for markup
            table.add_row(*(escape(cell) for cell in cells))
        Console(width=max(Console().width, 160)).print(table)
        return 0

    def check(self, args: argparse.Namespace) -> int:
        """Run the deep checks on every component (the registry has passed the others)."""
        manager = _manager(args)
        components = [c for c in manager.registry.all() if not args.kind or c.kind == args.kind]
        problems: list[Problem] = []
        notes: list[str] = []
        for component in components:
            problems.extend(deep_problems(component, notes))
        plugins = sorted({c.plugin for c in components})
        print(
            f"armtree {installed_version()}: checked {len(components)} components "
            f"of {len(plugins)} plugins"
        )
        for note in notes:
            print(f"note: {note}")
        for problem in problems:
            print(problem.error().format())
        # Installed plugins left out (each warned of once): problems here.
        left_out = [f"{why}" for why in manager.broken.values()]
        left_out += [error.format() for error in manager.refused.values()]
        for text in left_out:
            print(text)
        if problems or left_out:
            print(f"{len(problems) + len(left_out)} problem(s) found")
            return 2
        print("ok: every component fits its interface")
        return 0


class Schema:
    """``armtree schema``: the JSON Schema of trees and profiles for the installed plugins."""

    help = "write the JSON Schema of tree files and profiles (for editor completion)"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add -o."""
        parser.add_argument("-o", "--output", metavar="FILE", help="write here, not to stdout")

    def run(self, args: argparse.Namespace) -> int:
        """Build the schema from the registry and write it."""
        text = json.dumps(build_schema(_manager(args).registry), indent=2) + "\n"
        if args.output:
            try:
                Path(args.output).write_text(text)
            except OSError as exc:
                raise ConfigError(f"cannot write the schema: {exc}", file=args.output) from None
            print(f"wrote {args.output}")
        else:
            sys.stdout.write(text)
        return 0


@hookimpl
def armtree_commands() -> dict[str, Any]:
    """Register check, show, plugins, schema, hooks, new-plugin and sweep."""
    from armtree.cli.sweep.command import SweepCommand

    return {
        "check": Check(),
        "show": Show(),
        "plugins": Plugins(),
        "schema": Schema(),
        "hooks": HooksCommand(),
        "new-plugin": NewPluginCommand(),
        "sweep": SweepCommand(),
    }
