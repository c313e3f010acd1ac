"""``armtree export TREE --format btcpp -o FILE.xml`` and ``armtree export --palette``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from armtree import ConfigError
from armtree.cli.options import add_set_option
from armtree.hooks.plugin_manager import PluginManager, get_plugin_manager

from .writer import export_tree, palette


class ExportCommand:
    """``armtree export``: a tree, or the palette of every behaviour, as BehaviorTree.CPP XML."""

    help = "write a tree (or with --palette every behaviour's model) as BehaviorTree.CPP v4 XML"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """TREE, --format, -o, --palette, --rig."""
        parser.add_argument("tree", metavar="TREE", nargs="?", help="tree file or shipped tree")
        parser.add_argument(
            "--format",
            default="btcpp",
            choices=("btcpp",),
            help="btcpp: BehaviorTree.CPP v4 XML, as Groot2 and Nav2 read it (the default)",
        )
        parser.add_argument(
            "-o", "--output", metavar="FILE", help="write to FILE (default: stdout)"
        )
        parser.add_argument(
            "--palette",
            action="store_true",
            help="write the <TreeNodesModel> of every registered behaviour (Groot2's palette)",
        )
        parser.add_argument("--rig", metavar="PROFILE", help="profile to check the tree against")
        add_set_option(parser, "a value the check needs (a required tree parameter); not written")

    def run(self, args: argparse.Namespace) -> int:
        """Write the XML; exit 2 (nothing written) for an invalid tree."""
        manager: PluginManager = getattr(args, "manager", None) or get_plugin_manager(
            getattr(args, "plugin", None) or ()
        )
        if args.palette == (args.tree is not None):
            raise ConfigError("export: name a TREE, or give --palette (not both)")
        text = (
            palette(manager.registry)
            if args.palette
            else export_tree(args.tree, manager, args.rig, args.overrides)
        )
        if args.output is None:
            sys.stdout.write(text)
            return 0
        try:
            Path(args.output).write_text(text, encoding="utf-8")
        except OSError as exc:
            raise ConfigError(f"cannot write {args.output}: {exc.strerror or exc}") from None
        print(f"wrote {args.output}", file=sys.stderr)
        return 0
