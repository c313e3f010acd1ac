"""Type-check armtree (core/ and plugins/) with mypy, as CI does.

The package's folders are not named as it imports (core/ is ``armtree``, plugins/ is
``armtree.plugins``), and mypy finds a package by its folder's name, so this lays out
a tree of symbolic links named as the package imports and checks ``-p armtree`` there,
with pyproject.toml's ``[tool.mypy]`` settings. Paths in the report are the checkout's.
Run from a checkout: ``python tools/typecheck.py [--cache-dir DIR]``; exit 0 when clean.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
from pathlib import Path

from mypy import api

ROOT = Path(__file__).resolve().parent.parent


def link_tree(into: Path) -> Path:
    """Lay out ``into/armtree`` as the package imports: core/'s entries, plugins/ inside."""
    package = into / "armtree"
    package.mkdir(parents=True, exist_ok=True)
    entries = {p.name: p for p in (ROOT / "core").iterdir() if p.name != "__pycache__"}
    entries["plugins"] = ROOT / "plugins"
    for name, target in entries.items():
        link = package / name
        if not link.is_symlink():
            link.symlink_to(target, target_is_directory=target.is_dir())
    return package


def check(cache_dir: Path | None = None) -> tuple[str, int]:
    """mypy's report on the package (paths as in the checkout) and its exit status."""
    with tempfile.TemporaryDirectory(prefix="armtree-typecheck-") as tmp:
        link_tree(Path(tmp))
        cache = cache_dir or Path(tmp) / ".mypy_cache"
        args = [
            "--config-file",
            str(ROOT / "pyproject.toml"),
            "--cache-dir",
            str(cache),
            "-p",
            "armtree",
        ]
        here = os.getcwd()
        os.chdir(tmp)  # mypy finds -p packages from the working directory
        try:
            out, err, status = api.run(args)
        finally:
            os.chdir(here)
    report = re.sub(r"^armtree/plugins/", "plugins/", out + err, flags=re.M)
    report = re.sub(r"^armtree/", "core/", report, flags=re.M)
    return report, status


def main(argv: list[str] | None = None) -> int:
    """Print mypy's report; the exit status is mypy's."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache-dir", type=Path, help="mypy's cache (default: a temporary one)")
    args = parser.parse_args(argv)
    report, status = check(args.cache_dir)
    sys.stdout.write(report)
    return status


if __name__ == "__main__":
    sys.exit(main())
