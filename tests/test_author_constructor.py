"""A behaviour whose constructor raises is reported at its node with the exception's type,
the class, and the plugin's file and line; --debug adds the traceback (issue 29)."""

from __future__ import annotations

import pytest
from plugin_author import armtree, line_of, run_tree, write

SKILLS = """
    import py_trees
    from py_trees.common import Status

    import armtree


    def read_calibration(path):
        with open(path) as handle:
            return handle.read()


    class Boom(py_trees.behaviour.Behaviour):
        \"\"\"Needs a calibration file.\"\"\"

        def __init__(self, name: str, calibration: str = "missing.yaml"):
            super().__init__(name=name)
            self.data = read_calibration(calibration)

        def update(self):
            return Status.SUCCESS


    class Picky(armtree.Behaviour):
        \"\"\"Refuses, in its own words, what its parameters cannot be.\"\"\"

        PARAMS = (armtree.Param("colour", "str"),)

        def __init__(self, name, **params):
            super().__init__(name, **params)
            if params["colour"] == "plaid":
                raise armtree.ConfigError("colour: plaid is not a colour the camera sees")

        def update(self):
            return Status.SUCCESS


    @armtree.hookimpl
    def armtree_behaviours():
        return {"boom": Boom, "picky": Picky}
"""

TREE = """
    plugins: [my_skills.py]
    root:
      sequence:
        - success: {}
        - boom: {}
"""


def test_a_constructor_that_raises_is_named_with_its_type_class_and_plugin_line(tmp_path):
    folder = write(tmp_path, {"my_skills.py": SKILLS, "ctor_tree.yaml": TREE})
    done = run_tree(folder, "ctor_tree.yaml", "--quiet")
    assert done.returncode == 2, done.stdout + done.stderr
    raised = line_of(folder / "my_skills.py", "with open(path)")
    lines = done.stderr.splitlines()
    assert lines[0] == (
        f"{folder / 'ctor_tree.yaml'}:5:7: boom 'boom': the constructor of Boom (plugin "
        f"'my_skills') raised FileNotFoundError at {folder / 'my_skills.py'}:{raised}: "
        "[Errno 2] No such file or directory: 'missing.yaml'"
    )
    assert lines[1] == "(run again with --debug for the traceback)"
    assert "Traceback" not in done.stderr


def test_debug_shows_the_constructors_traceback(tmp_path):
    folder = write(tmp_path, {"my_skills.py": SKILLS, "ctor_tree.yaml": TREE})
    done = armtree(folder, "check", "ctor_tree.yaml", "--debug")
    assert done.returncode == 2
    assert "Traceback (most recent call last):" in done.stderr
    assert 'my_skills.py", line' in done.stderr and "in read_calibration" in done.stderr
    assert "FileNotFoundError" in done.stderr.splitlines()[-2]
    assert done.stderr.splitlines()[-1].endswith("'missing.yaml'")


def test_a_config_error_from_a_constructor_keeps_its_own_words(tmp_path):
    tree = "plugins: [my_skills.py]\nroot:\n  picky: {colour: plaid}\n"
    folder = write(tmp_path, {"my_skills.py": SKILLS, "t.yaml": tree})
    done = armtree(folder, "check", "t.yaml")
    assert done.returncode == 2
    assert done.stderr == (
        f"{folder / 't.yaml'}:3:3: picky 'picky': colour: plaid is not a colour the camera sees\n"
    )


def test_a_behaviour_without_update_is_refused_when_the_plugin_loads(tmp_path):
    skills = """
        import py_trees

        import armtree


        class Idle(py_trees.behaviour.Behaviour):
            \"\"\"Defines no update().\"\"\"


        @armtree.hookimpl
        def armtree_behaviours():
            return {"idle": Idle}
    """
    tree = "plugins: [my_skills.py]\nroot:\n  idle: {}\n"
    folder = write(tmp_path, {"my_skills.py": skills, "t.yaml": tree})
    done = run_tree(folder, "t.yaml", "--quiet")
    assert done.returncode == 2
    line = line_of(folder / "my_skills.py", "class Idle")
    assert done.stderr.startswith(
        f"{folder / 'my_skills.py'}:{line}: plugin 'my_skills': behaviour 'idle': class: Idle "
        "leaves update() undefined; expected a behaviour that defines update()"
    ), done.stderr


RAISES_IN = """
    import py_trees
    from py_trees.common import Status

    import armtree


    class Hello(py_trees.behaviour.Behaviour):
        \"\"\"Raises in PHASE.\"\"\"

        def setup(self, **kwargs):
            self.table = {}
            SETUP

        def update(self):
            UPDATE
            return Status.SUCCESS


    @armtree.hookimpl
    def armtree_behaviours():
        return {"hello": Hello}
"""


@pytest.mark.parametrize(("phase", "said"), [("setup", "setup"), ("update", "tick")])
def test_an_exception_in_setup_or_update_names_the_plugins_line(tmp_path, phase, said):
    raising = "self.table['calibration']"
    source = RAISES_IN.replace("PHASE", phase)
    source = source.replace("SETUP", raising if phase == "setup" else "pass")
    source = source.replace("UPDATE", raising if phase == "update" else "pass")
    tree = "plugins: [my_skills.py]\nroot:\n  sequence:\n    - hello: {}\n"
    folder = write(tmp_path, {"my_skills.py": source, "t.yaml": tree})
    done = run_tree(folder, "t.yaml", "--quiet")
    assert done.returncode == 1, done.stdout + done.stderr
    line = line_of(folder / "my_skills.py", raising)
    assert (
        f"why: KeyError in {said} of sequence/hello ({folder / 't.yaml'}:4) at "
        f"{folder / 'my_skills.py'}:{line}: 'calibration'"
    ) in done.stdout, done.stdout
