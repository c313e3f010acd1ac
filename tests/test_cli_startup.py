"""A command that needs no plugin's libraries does not load them (the CLI starts fast)."""

from __future__ import annotations

import subprocess
import sys

HEAVY = ("scipy.optimize", "scipy.spatial", "networkx", "aiohttp")


def _main_in_fresh_process(*argv: str) -> subprocess.CompletedProcess:
    code = (
        "import sys\n"
        "from armtree.cli.commandline import main\n"
        f"code = main({list(argv)!r})\n"
        f"print(code, sorted(m for m in {HEAVY!r} if m in sys.modules),"
        " 'armtree.plugins' in sys.modules)\n"
    )
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False
    )


def test_bad_options_are_refused_before_any_plugin_library_loads():
    done = _main_in_fresh_process("sweep", "load_ducky.yaml", "--seeds", "x")
    assert done.stdout.splitlines()[-1] == "2 [] True", done.stderr
    assert "--seeds x: give a range A-B" in done.stderr


def test_version_loads_no_plugin():
    done = _main_in_fresh_process("--version")
    version, loaded = done.stdout.splitlines()
    assert version.startswith("armtree ") and loaded == "0 [] False"
