"""An update() that returns no py_trees Status ends the run at its first tick (issue 29).

py_trees turns such a value into INVALID and ticks on; a tree with an update() that
forgot its return spun for minutes at full CPU. Now the run ends within that tick,
exit 1, naming the node, its class, the file and line of its update() and the value.
"""

from __future__ import annotations

import json

import pytest
from plugin_author import line_of, run_tree, write

SKILLS = """
    import py_trees
    from py_trees.common import Status

    import armtree


    class Forgetful(py_trees.behaviour.Behaviour):
        \"\"\"Says it is working, and forgets to return.\"\"\"

        def update(self):
            self.feedback_message = "working"


    class Wordy(armtree.Behaviour):
        \"\"\"Returns the status's name instead of the status.\"\"\"

        def update(self):
            return "SUCCESS"


    class Unset(py_trees.behaviour.Behaviour):
        \"\"\"Returns the status py_trees gives nodes that have not run.\"\"\"

        def update(self):
            return Status.INVALID


    class Fine(py_trees.behaviour.Behaviour):
        \"\"\"Does its job.\"\"\"

        def update(self):
            return Status.SUCCESS


    @armtree.hookimpl
    def armtree_behaviours():
        return {"forgetful": Forgetful, "wordy": Wordy, "unset": Unset, "fine": Fine}
"""


def tree(node: str) -> str:
    return f"""
        plugins: [my_skills.py]
        root:
          sequence:
            name: Root
            children:
              - fine: {{}}
              - {node}: {{}}
              - fine: {{}}
    """


@pytest.mark.parametrize(
    ("node", "cls", "said"),
    [
        (
            "forgetful",
            "Forgetful",
            "returned None from update(), not RUNNING, SUCCESS or FAILURE: "
            "did update() forget to return?",
        ),
        ("wordy", "Wordy", "returned 'SUCCESS' from update()"),
        ("unset", "Unset", "returned Status.INVALID from update()"),
    ],
)
def test_a_bad_status_ends_the_run_at_its_first_tick_naming_the_node_class_and_line(
    tmp_path, node, cls, said
):
    folder = write(tmp_path, {"my_skills.py": SKILLS, "t.yaml": tree(node)})
    done = run_tree(folder, "t.yaml", "--quiet", "--record", "rec", timeout=60)
    assert done.returncode == 1, done.stdout + done.stderr
    update_line = line_of(folder / "my_skills.py", f"class {cls}") + 3
    assert f"bad status at Root/{node} (" in done.stdout
    assert "t.yaml:7)" in done.stdout
    assert f"behaviour '{node}' (class {cls} at {folder / 'my_skills.py'}:{update_line})" in (
        done.stdout
    )
    assert said in done.stdout
    assert "Traceback" not in done.stdout + done.stderr
    records = [json.loads(line) for line in (folder / "rec" / "run.jsonl").read_text().splitlines()]
    result = records[-1]
    assert result["kind"] == "result" and result["ticks"] == 1, result
    assert result["failed_node"] == f"Root/{node}"
    # The node after it never ran.
    assert not [r for r in records if r.get("node") == "Root/fine#2" and r.get("to") != "INVALID"]
