"""A plugin author's folder for the tests of issue 29: files written into a temporary
folder and armtree's commands run on them in a subprocess, as the author runs them."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

RUN_TREE = Path(sys.executable).with_name("run-tree")
ARMTREE = Path(sys.executable).with_name("armtree")


def write(folder: Path, files: dict[str, str]) -> Path:
    """Write ``{relative path: text}`` (dedented) into ``folder``; return the folder."""
    for relative, text in files.items():
        path = folder / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text).lstrip("\n"))
    return folder


def command(
    folder: Path, program: Path, *args: str, timeout: float = 120, env: dict | None = None
) -> subprocess.CompletedProcess:
    """``program args`` run in ``folder`` (its output as text); fails the test past ``timeout``."""
    environment = {**os.environ, "COLUMNS": "200", **(env or {})}
    return subprocess.run(
        [str(program), *args],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=environment,
        stdin=subprocess.DEVNULL,
    )


def run_tree(folder: Path, *args: str, **options) -> subprocess.CompletedProcess:
    """``run-tree args`` in ``folder``."""
    return command(folder, RUN_TREE, *args, **options)


def armtree(folder: Path, *args: str, **options) -> subprocess.CompletedProcess:
    """``armtree args`` in ``folder``."""
    return command(folder, ARMTREE, *args, **options)


def line_of(path: Path, text: str) -> int:
    """The 1-based number of the first line of ``path`` that contains ``text``."""
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        if text in line:
            return number
    raise AssertionError(f"{text!r} is not in {path}")
