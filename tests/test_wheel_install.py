"""A wheel installed non-editable into a fresh venv runs ``run-tree load_ducky.yaml`` anywhere."""

import shutil
import site
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: What the wheel is built from (copied, so the build leaves nothing in the work tree).
SOURCES = ("pyproject.toml", "README.md", "core", "plugins", "trees", "hardware")


def sh(*args, cwd=None, timeout=300):
    proc = subprocess.run(
        [str(a) for a in args], cwd=cwd, capture_output=True, text=True, timeout=timeout
    )
    assert proc.returncode == 0, f"{args}\n{proc.stdout}\n{proc.stderr}"
    return proc


def build_wheel(tmp_path: Path) -> Path:
    src = tmp_path / "src"
    src.mkdir()
    for name in SOURCES:
        path = ROOT / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=shutil.ignore_patterns("__pycache__"))
        elif path.exists():
            shutil.copy2(path, src / name)
    dist = tmp_path / "dist"
    sh(sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-w", dist, src)
    (wheel,) = dist.glob("armtree-*.whl")
    return wheel


def fresh_venv(tmp_path: Path) -> Path:
    """A venv whose dependencies come from the test venv, but not its editable armtree."""
    venv = tmp_path / "venv"
    sh(sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", venv)
    (purelib,) = venv.glob("lib/python*/site-packages")
    # A plain path line adds the test venv's packages without running its .pth files,
    # so the editable armtree finder stays off and the wheel's armtree is imported.
    (purelib / "test_venv_deps.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    return venv


@pytest.mark.slow
def test_wheel_installed_in_a_fresh_venv_runs_load_ducky_from_an_empty_directory(tmp_path):
    wheel = build_wheel(tmp_path)
    venv = fresh_venv(tmp_path)
    python = venv / "bin" / "python"
    sh(
        sys.executable,
        "-m",
        "pip",
        "--python",
        python,
        "install",
        "--no-deps",
        "--no-build-isolation",
        "--no-index",
        wheel,
    )
    empty = tmp_path / "anywhere"
    empty.mkdir()
    where = sh(python, "-c", "import armtree; print(armtree.__file__)", cwd=empty).stdout
    assert Path(where.strip()).is_relative_to(venv), where
    run = subprocess.run(
        [venv / "bin" / "run-tree", "load_ducky.yaml", "--quiet", "--timeout", "600"],
        cwd=empty,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert "result: SUCCESS" in run.stdout
    assert list((empty / "runs").glob("load_ducky-*/run.jsonl"))
