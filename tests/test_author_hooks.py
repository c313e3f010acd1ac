"""A misspelt hook is reported first, at its line, with did-you-mean; an installed plugin
that is broken blocks only the trees that use it (issue 29)."""

from __future__ import annotations

import textwrap

import pytest
from plugin_author import armtree, line_of, run_tree, write

HELLO = textwrap.dedent(
    """
    import py_trees
    from py_trees.common import Status

    import armtree


    class Hello(py_trees.behaviour.Behaviour):
        \"\"\"Says hello.\"\"\"

        def update(self):
            self.feedback_message = "hello"
            return Status.SUCCESS


"""
)

TREE = """
    plugins: [my_skills.py]
    root:
      sequence:
        - hello: {}
"""


@pytest.mark.parametrize(
    ("registration", "misspelt", "meant"),
    [
        (
            "@armtree.hookimpl\ndef armtree_behaviour():\n    return {'hello': Hello}\n",
            "armtree_behaviour",
            "armtree_behaviours",
        ),
        (
            "def armtre_behaviours():\n    return {'hello': Hello}\n",
            "armtre_behaviours",
            "armtree_behaviours",
        ),
        (
            "class Plugin:\n    @armtree.hookimpl\n    def armtree_behaviour(self):\n"
            "        return {'hello': Hello}\n\n\nplugin = Plugin()\n"
            "armtree_arm = plugin.armtree_behaviour\n",
            "armtree_arm",
            "armtree_arms",
        ),
    ],
)
def test_a_misspelt_hook_is_reported_first_at_its_line_with_did_you_mean(
    tmp_path, registration, misspelt, meant
):
    source = HELLO + registration
    folder = write(tmp_path, {"my_skills.py": source, "t.yaml": TREE})
    done = run_tree(folder, "t.yaml", "--quiet")
    assert done.returncode == 2, done.stdout + done.stderr
    first = done.stderr.splitlines()[0]
    # A bound method under another name is found at its own def line.
    line = line_of(folder / "my_skills.py", f"def {misspelt.replace('_arm', '_behaviour')}")
    assert first.startswith(
        f"{folder / 'my_skills.py'}:{line}: plugin 'my_skills': {misspelt}() is not an armtree "
        f"hook; did you mean {meant!r}?"
    ), done.stderr
    assert "-p no:my_skills" in first and "Traceback" not in done.stderr


def installed(site, name: str, module: str) -> dict[str, str]:
    """The files of an installed distribution ``armtree-NAME`` whose entry point is
    ``module`` (a dist-info folder beside it: what pip would leave)."""
    info = f"armtree_{name}-0.1.dist-info"
    return {
        f"site/armtree_{name}.py": module,
        f"site/{info}/METADATA": f"Metadata-Version: 2.1\nName: armtree-{name}\nVersion: 0.1\n",
        f"site/{info}/entry_points.txt": f"[armtree]\n{name} = armtree_{name}\n",
    }


BROKEN = {
    "misspelt": HELLO
    + "@armtree.hookimpl\ndef armtree_behaviour():\n    return {'hello': Hello}\n",
    "unimportable": HELLO + "import armtree_missing_dependency\n",
    "raising": HELLO
    + "@armtree.hookimpl\ndef armtree_behaviours():\n    return {'hello': Hello, **{}['x']}\n",
    "misfit": HELLO.replace("def update(self):", "def update(self, blackboard):")
    + "@armtree.hookimpl\ndef armtree_behaviours():\n    return {'hello': Hello}\n",
}


@pytest.mark.parametrize("kind", sorted(BROKEN))
def test_a_broken_installed_plugin_blocks_only_the_trees_that_use_it(tmp_path, kind):
    files = {
        **installed(tmp_path, "greeter", BROKEN[kind]),
        "uses_it.yaml": "root:\n  sequence:\n    - hello: {}\n",
        "other.yaml": "root:\n  sequence:\n    - success: {}\n",
    }
    folder = write(tmp_path, files)
    env = {"PYTHONPATH": str(folder / "site")}
    done = run_tree(folder, "other.yaml", "--quiet", "--record", "rec", env=env)
    assert done.returncode == 0, done.stderr
    (warning,) = done.stderr.splitlines()
    assert warning.startswith("warning: ") and "'greeter'" in warning and "left out" in warning
    assert "result: SUCCESS" in done.stdout
    refused = armtree(folder, "check", "uses_it.yaml", env=env)
    assert refused.returncode == 2
    error = refused.stderr.splitlines()[-1]
    assert error.startswith(f"{folder / 'uses_it.yaml'}:3:7: unknown node type 'hello'")
    if kind == "misfit":
        line = line_of(folder / "site" / "armtree_greeter.py", "def update")
        assert f"it is left out: {folder / 'site' / 'armtree_greeter.py'}:{line}:" in error
    else:
        assert "an installed plugin that may provide it did not load ('greeter': " in error
    if kind == "misspelt":
        assert "armtree_behaviour() is not an armtree hook; did you mean" in error
    if kind == "raising":  # the hook's own line, the exception's type and text
        line = line_of(folder / "site" / "armtree_greeter.py", "return {'hello'")
        assert (
            f"{folder / 'site' / 'armtree_greeter.py'}:{line}: plugin 'greeter': "
            "armtree_behaviours() raised KeyError: 'x'"
        ) in error
    if kind == "unimportable":
        assert "ModuleNotFoundError" in error and "armtree_missing_dependency" in error


def test_plugins_check_counts_a_broken_installed_plugin_as_a_problem(tmp_path):
    folder = write(tmp_path, installed(tmp_path, "greeter", BROKEN["misspelt"]))
    done = armtree(folder, "plugins", "--check", env={"PYTHONPATH": str(folder / "site")})
    assert done.returncode == 2, done.stdout
    assert "armtree_behaviour() is not an armtree hook; did you mean" in done.stdout
    assert done.stdout.splitlines()[-1] == "1 problem(s) found"


def test_a_chosen_plugin_whose_hook_raises_is_an_error_at_its_line(tmp_path):
    source = HELLO + "@armtree.hookimpl\ndef armtree_behaviours():\n    return {}['x']\n"
    folder = write(tmp_path, {"my_skills.py": source, "t.yaml": TREE})
    done = run_tree(folder, "t.yaml", "--quiet")
    assert done.returncode == 2, done.stdout + done.stderr
    line = line_of(folder / "my_skills.py", "return {}['x']")
    assert done.stderr.splitlines()[0].startswith(
        f"{folder / 'my_skills.py'}:{line}: plugin 'my_skills': armtree_behaviours() raised "
        "KeyError: 'x'. Fix the plugin, or skip it with -p no:my_skills"
    ), done.stderr
    assert "Traceback" not in done.stderr


def test_a_hook_under_another_name_with_specname_is_a_hook(tmp_path):
    source = HELLO + (
        "@armtree.hookimpl(specname='armtree_behaviours')\n"
        "def my_behaviours():\n    return {'hello': Hello}\n"
    )
    folder = write(tmp_path, {"my_skills.py": source, "t.yaml": TREE})
    done = run_tree(folder, "t.yaml", "--quiet")
    assert done.returncode == 0, done.stdout + done.stderr
    assert "result: SUCCESS" in done.stdout


def test_a_plugin_that_exits_while_imported_is_a_plugin_error_not_a_silent_success(tmp_path):
    folder = write(tmp_path, {"my_skills.py": "import sys\nsys.exit(0)\n", "t.yaml": TREE})
    done = armtree(folder, "check", "t.yaml")
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stderr.splitlines()[0] == (
        f"{folder / 't.yaml'}:1:11: plugin '{folder / 'my_skills.py'}' failed to import: it called "
        "sys.exit(0) while being imported. Give an importable module name or a path to a .py file"
    )
