"""Installing a plugin package into a folder with pip and running its own tests there.

``pip install --no-deps --no-build-isolation --target SITE`` is a real install
(the distribution's metadata and entry points land in SITE); with SITE on
``PYTHONPATH`` armtree finds the plugin through its entry point, as after a
user's ``pip install``, while armtree itself is the one under test.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path


def pip_install(site: Path, *packages: Path) -> None:
    """Install ``packages`` (folders or wheels) into ``site``, offline, without dependencies."""
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            "--no-index",
            "--target",
            str(site),
            *map(str, packages),
        ],
        check=True,
        capture_output=True,
        timeout=600,
    )


def run_package_tests(package: Path, site: Path, cwd: Path) -> subprocess.CompletedProcess:
    """``pytest`` on ``package/tests`` from ``cwd`` with ``site`` on the path (autoload on)."""
    env = dict(os.environ, PYTHONPATH=str(site))
    env.pop("ARMTREE_DISABLE_PLUGIN_AUTOLOAD", None)
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "-p",
            "no:xdist",
            "--rootdir",
            str(package),
            str(package / "tests"),
        ],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
