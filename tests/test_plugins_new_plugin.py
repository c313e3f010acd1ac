"""`armtree new-plugin`: each kind generated, installed with pip, its tests and its tree run.

Each package is written into a temporary folder and installed with
``pip install --no-deps --no-build-isolation --target`` (that folder then put on
``PYTHONPATH``), so armtree finds it through its entry point exactly as after a
user's ``pip install``. Each package's own tests run its demo tree
through ``run-tree``'s entry function on the simulation and check the world.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from package_install import pip_install, run_package_tests

from armtree.cli.commandline import main
from armtree.cli.scaffold import KINDS, plugin_names, render_package

# Each test installs a package and runs its suite in a subprocess: on a loaded machine
# that outlasts the suite's default 120 s per test.
pytestmark = [pytest.mark.slow, pytest.mark.timeout(600)]


def install(kind: str, root: Path) -> tuple[Path, Path]:
    """Generate the ``kind`` package under ``root`` and pip-install it; (package, site)."""
    assert main(["new-plugin", f"made_{kind}", "--kind", kind, "--dir", str(root)]) == 0
    package, site = root / f"armtree-made-{kind}", root / "site"
    pip_install(site, package)
    return package, site


@pytest.mark.parametrize("kind", KINDS)
def test_a_generated_package_installs_and_its_tests_and_tree_pass(tmp_path, kind, capsys):
    package, site = install(kind, tmp_path)
    capsys.readouterr()
    proc = run_package_tests(package, site, cwd=package)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    assert " passed" in proc.stdout and "skipped" not in proc.stdout


def test_every_kind_is_written_with_its_parts(tmp_path, capsys):
    assert main(["new-plugin", "my-gripper", "--kind", "arm", "--dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    root = tmp_path / "armtree-my-gripper"
    assert f"wrote {root}/ (arm plugin my_gripper)" in out
    for part in ("plugin", "kinematics", "driver", "emulator"):
        assert (root / "src" / "armtree_my_gripper" / f"{part}.py").is_file()
    pyproject = (root / "pyproject.toml").read_text()
    assert 'my_gripper = "armtree_my_gripper.plugin"' in pyproject
    assert '"armtree>=0.' in pyproject  # the versions it supports, also in ARMTREE_REQUIRES
    profile = yaml.safe_load((root / "hardware" / "sim_my_gripper.yaml").read_text())
    assert profile["arm"] == {"type": "my_gripper", "port": "sim"}
    for kind in KINDS:
        files = render_package("x", kind)
        assert {"pyproject.toml", "README.md", "trees/x_demo.yaml", "tests/test_x.py"} <= set(files)
        assert all("${" not in text for text in files.values()), kind


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["new-plugin", "2fast", "--kind", "skill"], "'2fast' is not a plugin name"),
        (["new-plugin", "class", "--kind", "skill"], "'class' is not a plugin name"),
        (["new-plugin", "vicra", "--kind", "arm"], "arm 'vicra' already exists (plugin 'vicra')"),
    ],
)
def test_bad_names_are_refused_and_nothing_is_written(tmp_path, capsys, argv, message):
    assert main([*argv, "--dir", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_an_existing_folder_is_not_overwritten(tmp_path, capsys):
    target = tmp_path / "armtree-mine"
    target.mkdir()
    (target / "keep.txt").write_text("mine")
    assert main(["new-plugin", "mine", "--kind", "skill", "--dir", str(tmp_path)]) == 2
    assert "already exists and is not empty" in capsys.readouterr().err
    assert [p.name for p in target.iterdir()] == ["keep.txt"]


def test_names_are_derived_consistently():
    names = plugin_names("Wrist-Cam")
    assert names["name"] == "wrist_cam" and names["class_name"] == "WristCam"
    assert names["package"] == "armtree_wrist_cam" and names["dist"] == "armtree-wrist-cam"
