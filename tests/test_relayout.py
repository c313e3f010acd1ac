"""tools/relayout.py on a small checkout in the old layout: it moves, rewrites every kind of
reference, refuses a module it does not place, and does nothing when run again."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "tools" / "relayout.py"

OLD = {
    "core/__init__.py": '_LAZY = {\n    "run": "runtime",\n}\n',
    "core/errors.py": "class ConfigError(ValueError):\n    pass\n",
    "core/runtime.py": (
        '"""The runtime (:mod:`armtree.pacing`)."""\n'
        "from .errors import ConfigError\n"
        "from .pacing import Pacer\n"
        "from .failure_report import EXIT_FAILURE\n\n\n"
        "def run():\n    return Pacer, ConfigError, EXIT_FAILURE\n"
    ),
    "core/pacing.py": "class Pacer:\n    pass\n",
    "core/failure_report.py": "EXIT_FAILURE = 1\n",
    "core/cli.py": "from . import runtime\n\n\ndef main():\n    return runtime.run()\n",
    "core/motion/__init__.py": "",
    "core/motion/geometry.py": "from ..errors import ConfigError\n",
    "core/motion/urdf.py": "from .geometry import ConfigError\n",  # another branch's new file
    "plugins/__init__.py": "",
    "plugins/sim/__init__.py": "",
    "plugins/sim/plugin.py": (
        "from armtree.runtime import EXIT_FAILURE, run\n"
        "from armtree import cli, motion\n"
        'PATCH = "armtree.runtime.time"\n'
    ),
    "tests/test_x.py": (
        "import subprocess\n"
        'ARGS = ["-m", "armtree.cli", "check"]\n'
        'SCHEMA = "$schema=armtree.schema.json"\n'
        'PLUGIN = "from armtree.runtime import EXIT_FAILURE\\n"\n'
    ),
    "docs/a.md": "See core/runtime.py, core/motion/ and `armtree.cli.main`.\n",
    "pyproject.toml": (
        '[project.scripts]\narmtree = "armtree.cli:main"\n\n'
        '[tool.setuptools]\npackages = [\n    "armtree",\n    "armtree.motion",\n'
        '    "armtree.plugins",\n    "armtree.plugins.sim",\n]\n'
    ),
}


def _git(tmp: Path, *args: str) -> str:
    done = subprocess.run(["git", *args], cwd=tmp, capture_output=True, text=True, check=True)
    return done.stdout


@pytest.fixture
def checkout(tmp_path: Path) -> Path:
    for name, text in OLD.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    (tmp_path / "tools").mkdir()
    shutil.copy(SCRIPT, tmp_path / "tools" / "relayout.py")
    _git(tmp_path, "init", "-q")
    _git(tmp_path, "add", "-A")
    return tmp_path


def _relayout(tmp: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "tools/relayout.py", "--no-ruff"],
        cwd=tmp,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


def test_it_moves_rewrites_and_then_does_nothing(checkout: Path):
    assert _relayout(checkout).returncode == 0
    runner = (checkout / "core/runtime/runner.py").read_text()
    assert "from armtree.errors import ConfigError" in runner
    assert "from .pacing import Pacer" in runner
    assert ":mod:`armtree.runtime.pacing`" in runner
    assert "from .failure_report import EXIT_FAILURE" in runner
    assert (
        "from armtree.runtime import runner as runtime"
        in (checkout / "core/cli/commandline.py").read_text()
    )
    assert (checkout / "core/maths/motion/urdf.py").is_file()
    assert (
        "from armtree.errors import ConfigError"
        in (checkout / "core/maths/motion/geometry.py").read_text()
    )
    plugin = (checkout / "plugins/sim/plugin.py").read_text()
    # a name the runner only imports comes from the module that defines it
    assert "from armtree.runtime.failure_report import EXIT_FAILURE" in plugin
    assert "from armtree.runtime.runner import run" in plugin
    assert "from armtree.cli import commandline as cli" in plugin
    assert "from armtree.maths import motion" in plugin
    assert '"armtree.runtime.runner.time"' in plugin
    test = (checkout / "tests/test_x.py").read_text()
    assert '"armtree.cli.commandline"' in test and "armtree.schema.json" in test
    # an import written inside a string is pointed at the defining module too
    assert '"from armtree.runtime.failure_report import EXIT_FAILURE\\n"' in test
    assert (checkout / "docs/a.md").read_text() == (
        "See core/runtime/runner.py, core/maths/motion/ and `armtree.cli.commandline.main`.\n"
    )
    pyproject = (checkout / "pyproject.toml").read_text()
    assert 'armtree = "armtree.cli.commandline:main"' in pyproject
    assert '"armtree.maths.motion",' in pyproject and '"armtree.runtime",' in pyproject
    assert '"run": "runtime.runner"' in (checkout / "core/__init__.py").read_text()

    _git(checkout, "add", "-A")
    again = _relayout(checkout)
    assert again.returncode == 0 and "0 moves, 0 files rewritten" in again.stdout
    assert _git(checkout, "diff") == ""  # the second run changed no file


def test_it_refuses_a_module_it_does_not_place(checkout: Path):
    (checkout / "core/tree_reader.py").write_text("")
    done = _relayout(checkout)
    assert done.returncode != 0 and "tree_reader.py" in done.stderr
    assert (checkout / "core/runtime.py").is_file()  # nothing moved
