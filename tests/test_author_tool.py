"""rig.tool: a third-party skill grips with whatever tool the rig has (issue 29).

A skill that switched the suction pump directly did what it meant on a rig with a
pump and something else, or nothing, on another; through ``rig.tool`` it grips on
a suction cup, a gripper and a plugin's own tool alike.
"""

from __future__ import annotations

import json

import pytest
from plugin_author import run_tree, write

from armtree.api.clock import VirtualClock
from armtree.api.rig import ArmTool, MotionHandle, MotionStatus, Rig, Tool

SKILLS = """
    from py_trees.common import Status

    import armtree
    from armtree.api.rig import MotionStatus


    class GripAndLetGo(armtree.Behaviour):
        \"\"\"Grip with the rig's tool, check it holds, let go, check it does not.\"\"\"

        PARAMS = (armtree.Param("kinds", "any", None, doc="output: the tool's kind", io="out"),)
        RESOURCES = ("tool",)

        def initialise(self):
            self.steps = [("grip", True), ("release", False)]
            self.handle = None

        def update(self):
            tool = self.rig.tool
            if self.handle is None:
                if not self.steps:
                    return Status.SUCCESS
                self.word, self.want = self.steps.pop(0)
                self.handle = getattr(tool, self.word)()
            if not self.handle.done:
                return Status.RUNNING
            if self.handle.status is not MotionStatus.DONE:
                self.feedback_message = f"{self.word} failed: {self.handle.error}"
                return Status.FAILURE
            if tool.holding is not self.want:
                self.feedback_message = f"after {self.word} the {tool.kind} says {tool.holding}"
                return Status.FAILURE
            self.feedback_message = f"{self.word}: {tool.kind} holding={tool.holding}"
            self.output("kinds", tool.kind)
            self.handle = None
            return Status.RUNNING


    @armtree.hookimpl
    def armtree_behaviours():
        return {"grip_and_let_go": GripAndLetGo}
"""

TREE = """
    plugins: [my_skills.py]
    root:
      grip_and_let_go: {kinds: "{kind}"}
"""


@pytest.mark.parametrize(
    ("rig", "kind"), [("sim_dobot", "suction"), ("sim_vicra", "gripper"), ("sim_dh", "gripper")]
)
def test_a_plugin_skill_grips_with_whatever_tool_the_rig_has(tmp_path, rig, kind):
    folder = write(tmp_path, {"my_skills.py": SKILLS, "t.yaml": TREE})
    done = run_tree(folder, "t.yaml", "--rig", rig, "--quiet", "--record", "rec")
    assert done.returncode == 0, done.stdout + done.stderr
    records = [json.loads(line) for line in (folder / "rec" / "run.jsonl").read_text().splitlines()]
    said = [r["message"] for r in records if r["kind"] == "feedback"]
    assert f"grip: {kind} holding=True" in said and f"release: {kind} holding=False" in said
    writes = [r["value"] for r in records if r["kind"] == "blackboard" and r["key"] == "/kind"]
    assert writes == [kind, kind]


class Magnet(Tool):
    """A plugin's own tool: an electromagnet switched at once."""

    kind = "magnet"

    def __init__(self) -> None:
        self.on = False

    def _switch(self, on: bool) -> MotionHandle:
        self.on = on
        handle = MotionHandle(f"magnet {'on' if on else 'off'}")
        handle.update(MotionStatus.DONE)
        return handle

    def grip(self) -> MotionHandle:
        return self._switch(True)

    def release(self) -> MotionHandle:
        return self._switch(False)

    @property
    def holding(self) -> bool:
        return self.on


def test_a_plugin_tool_is_what_the_shipped_grip_step_uses():
    from armtree.api.skill.actions import Grip, State

    rig = Rig(profile=None, clock=VirtualClock(), tool=Magnet())
    step = Grip(rig, True)
    step.start()
    assert step.poll() is State.DONE and rig.tool.holding
    step = Grip(rig, False)
    step.start()
    assert step.poll() is State.DONE and not rig.tool.holding
    assert Grip(Rig(profile=None, clock=VirtualClock()), True).poll() is State.FAILED


def test_a_rig_built_with_an_arm_gets_the_arms_own_tool():
    class Arm:
        tool_kind = "gripper"

    rig = Rig(profile=None, clock=VirtualClock(), arm=Arm())  # type: ignore[arg-type]
    assert isinstance(rig.tool, ArmTool) and rig.tool.kind == "gripper"


def test_a_step_on_a_rig_without_the_part_it_drives_names_the_part_and_the_fix():
    """A plugin skill that forgot ``NEEDS = ("arm",)`` is told so, rather than failing
    on ``None`` somewhere inside a step."""
    from armtree.api.skill.actions import ArmHome

    home = ArmHome(Rig(profile=None, clock=VirtualClock()))  # type: ignore[arg-type]
    with pytest.raises(
        RuntimeError, match="this rig has no arm: a skill that uses it lists it in NEEDS"
    ):
        home.start()
