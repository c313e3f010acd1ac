"""--watch: a changed tree is validated, swapped in at a safe point; an invalid one is reported."""

import asyncio
import re
from types import SimpleNamespace

import py_trees
from monitor_helpers import COUNT_TREE, Page, run_tree

import armtree
from armtree.api.clock import VirtualClock
from armtree.api.rig import Rig
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.tree import Tree
from armtree.runtime.runlog import read_log
from armtree.runtime.runner import Run


class Arm:
    """An arm that is moving or holding as the test says."""

    def __init__(self):
        self.moving = False
        self.tool = SimpleNamespace(suction=False)

    def busy(self):
        return self.moving

    def stop(self):
        pass


class Place(armtree.Behaviour):
    """A leaf that commands the tool, as place and release do."""

    RESOURCES = ("arm", "tool")

    def update(self):
        return py_trees.common.Status.RUNNING


class Swapper:
    """Asks for a swap at ``at`` and notes the tick each tree was replaced at."""

    def __init__(self, new_tree, at, arm):
        self.new_tree, self.at, self.arm = new_tree, at, arm
        self.replaced = []
        self.script = {}

    @armtree.hookimpl
    def armtree_tick(self, run):
        for key, value in self.script.get(run.tick_count, {}).items():
            setattr(self.arm if key == "moving" else self.arm.tool, key, value)
        if run.tick_count == self.at:
            run.replace_tree(self.new_tree)

    @armtree.hookimpl
    def armtree_tree_replaced(self, run, previous):
        self.replaced.append((run.tick_count, previous.name, run.tree.name))


def swap_run(new_root, script, max_ticks=30):
    arm = Arm()
    clock = VirtualClock()
    rig = Rig(profile=None, clock=clock, arm=arm)
    old = Tree(name="old", root=py_trees.behaviours.Running(name="Old"), source=None)
    new = Tree(name="new", root=new_root, source=None)
    swapper = Swapper(new, 3, arm)
    swapper.script = script
    manager = PluginManager(autoload=False)
    manager.register(swapper, "swapper")
    run = Run(old, rig, manager=manager, max_ticks=max_ticks, record=False, handle_signals=False)
    run.execute()
    return swapper, run


def test_the_swap_waits_for_the_arm_to_stop_moving_and_the_old_tree_is_halted():
    new_root = py_trees.behaviours.Running(name="New")
    swapper, run = swap_run(new_root, {1: {"moving": True}, 8: {"moving": False}})
    assert swapper.replaced == [(8, "old", "new")]  # asked at 3, swapped once idle
    assert run.tree.name == "new" and run.root is new_root
    assert run.node_paths == ("New",)


def test_with_something_held_only_a_tree_that_starts_by_handling_the_tool_is_swapped_in():
    held = {1: {"suction": True}}
    swapper, _ = swap_run(py_trees.behaviours.Running(name="New"), held)
    assert swapper.replaced == []  # never safe: it would drop what the tool holds
    place = Place("Put it down")
    root = py_trees.composites.Sequence("New", memory=True, children=[place])
    swapper, run = swap_run(root, held)
    assert swapper.replaced == [(3, "old", "new")]


def test_an_invalid_change_is_reported_and_a_valid_one_replaces_the_running_tree(tmp_path):
    (tmp_path / "count.yaml").write_text(COUNT_TREE)
    args = ["count.yaml", "--watch", "--monitor", "0", "--record", "rec", "--realtime"]
    proc = run_tree(*args, cwd=tmp_path)
    try:
        url = proc.url()

        async def scenario():
            page = await Page.open(url)
            await page.next("state")
            proc.wait_for("Root/Count: INVALID -> RUNNING")
            (tmp_path / "count.yaml").write_text(
                COUNT_TREE.replace("duration: 30", "durration: 30")
            )
            news = await page.next("watch", lambda m: m["kind"] == "invalid", timeout=30)
            proc.wait_for("Root/Count: RUNNING -> SUCCESS", timeout=30)  # the old tree went on
            await asyncio.sleep(0.3)
            (tmp_path / "count.yaml").write_text(
                COUNT_TREE.replace("name: Root", "name: Second").replace(
                    "duration: 30", "duration: 2"
                )
            )
            state = await page.next("state", lambda m: m["tree"]["nodes"][-1]["path"] == "Second")
            await page.close()
            return news, state

        news, state = asyncio.run(scenario())
        proc.wait_for("Second/Wait: INVALID -> RUNNING", timeout=30)
        code, err = proc.interrupt()
    finally:
        proc.kill()
    # The page showed the errors, with their file, line and column.
    assert any("tick_counter has no parameter 'durration'" in e for e in news["errors"])
    assert "running tree goes on" in news["text"]
    assert [n["name"] for n in state["tree"]["nodes"]] == ["Count", "Wait", "Second"]
    assert code == 130
    assert "watch: the changed tree is not valid; the running tree goes on" in err
    assert re.search(r"count\.yaml:7:\d+: tick_counter has no parameter 'durration'", err)
    assert "watch: swapped in the changed tree at tick" in err
    log = read_log(tmp_path / "rec" / "run.jsonl")
    failed = [r for r in log if r.get("event") == "reload_failed"]
    assert failed and any("durration" in e for e in failed[0]["errors"])
    reload = next(r for r in log if r.get("event") == "reload")
    trees = [r for r in log if r["kind"] == "tree"]
    assert [t["nodes"][-1]["path"] for t in trees] == ["Root", "Second"]
    assert trees[1]["tick"] == reload["tick"]
    halted = [r for r in log if r["kind"] == "status" and r["node"] == "Root/Wait"]
    assert halted[-1]["to"] == "INVALID" and halted[-1]["tick"] == reload["tick"]
