"""examples/: two external plugins, each pip-installed into the test environment and its own
tests run there (they run its tree on the simulation and let the world judge it)."""

from __future__ import annotations

from pathlib import Path

import pytest
from package_install import pip_install, run_package_tests

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

# Each test installs a package and runs its suite in a subprocess: on a loaded machine
# that outlasts the suite's default 120 s per test.
pytestmark = [pytest.mark.slow, pytest.mark.timeout(600)]


@pytest.mark.parametrize("example", ["stack", "uarm_swift_pro"])
def test_an_example_installs_and_its_tests_pass(tmp_path, example):
    site = tmp_path / "site"
    pip_install(site, EXAMPLES / example)
    # From another folder, so the tests import the installed package, not its source.
    proc = run_package_tests(EXAMPLES / example, site, cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    assert " passed" in proc.stdout and "skipped" not in proc.stdout
