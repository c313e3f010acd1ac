"""Runs judged by their declared outcomes: false successes, events at their tick, failure chains."""

from __future__ import annotations

import textwrap

import pytest
from sim_fakes import FakeEmulator

from armtree import load_tree, run
from armtree.cli.commandline import run_tree_main
from armtree.plugins.sim.scene import parse_scene
from armtree.plugins.sim.world import World
from armtree.runtime.runlog import read_log


def write(path, text):
    path.write_text(textwrap.dedent(text))
    return path


def result_record(directory):
    log = read_log(directory / "run.jsonl")
    assert log[-1]["kind"] == "result"
    return log, log[-1]


def test_a_success_the_world_disagrees_with_is_a_false_success_and_exits_1(tmp_path, capsys):
    tree = write(
        tmp_path / "t.yaml",
        """\
        rig: sim_dobot
        expect:
          - {object: ducky, "on": duckybot}
          - {held: nothing}
        root: {success: {}}
        """,
    )
    code = run_tree_main([str(tree), "--quiet", "--record", str(tmp_path / "run")])
    out = capsys.readouterr().out
    assert code == 1
    lines = out.splitlines()
    assert lines[0] == "result: SUCCESS  (exit 1)"
    assert lines[1] == (
        "FALSE SUCCESS: the tree ended SUCCESS but the world disagrees: "
        "ducky on duckybot (ducky on table)"
    )
    assert "expect: ✗ ducky on duckybot (ducky on table)" in lines
    assert "expect: ✓ held: nothing (the tool holds nothing)" in lines
    _, result = result_record(tmp_path / "run")
    assert result["status"] == "SUCCESS" and result["exit_code"] == 1
    assert result["verdict"] == "false success"
    assert [(e["expect"], e["status"], e["measured"]) for e in result["expectations"]] == [
        ("ducky on duckybot", "fail", "table"),
        ("held: nothing", "pass", "nothing"),
    ]


def test_a_failure_while_the_world_is_fine_is_reported_as_a_false_failure(tmp_path, capsys):
    tree = write(
        tmp_path / "t.yaml",
        """\
        rig: sim_dobot
        expect: [{held: nothing}, {collisions: 0}]
        root: {failure: {}}
        """,
    )
    code = run_tree_main([str(tree), "--quiet", "--record", str(tmp_path / "run")])
    lines = capsys.readouterr().out.splitlines()
    assert code == 1
    assert lines[1] == "false failure: the tree ended FAILURE but every expectation holds"
    assert result_record(tmp_path / "run")[1]["verdict"] == "false failure"


@pytest.mark.parametrize(
    ("root", "code", "verdict"), [("success", 0, "success"), ("failure", 1, "failure")]
)
def test_without_ground_truth_each_expectation_is_not_checked_and_the_tree_decides(
    tmp_path, capsys, root, code, verdict
):
    """A rig with no simulated world (hardware): nothing can contradict the tree, nor confirm it."""
    tree = write(
        tmp_path / "t.yaml",
        f"""\
        tree: bare
        expect: [{{collisions: 0}}, {{held: nothing}}]
        root: {{{root}: {{name: Done}}}}
        """,
    )
    assert run_tree_main([str(tree), "--quiet", "--record", str(tmp_path / "run")]) == code
    lines = capsys.readouterr().out.splitlines()
    assert "expect: ? collisions <= 0 (not checked: no ground truth on this rig)" in lines
    assert not [line for line in lines if "false" in line.lower()]
    _, result = result_record(tmp_path / "run")
    assert result["verdict"] == verdict
    assert [(e["status"], e["measured"]) for e in result["expectations"]] == [
        ("not checked", None),
        ("not checked", None),
    ]


COLLIDE = """\
rig: sim_dobot
expect: [{collisions: 0}]
root:
  sequence:
    name: Root
    children:
      - move_to: {name: Swing, to: [150, -110, 30]}
      - wait: {seconds: 1}
"""
#: A post on the arc the tool swings along from home (the planner does not know it).
POST = "world.objects.post={kind: obstacle, at: [178, -50], size: [20, 20, 80]}"


def test_a_collision_ends_the_run_as_failure_naming_the_bodies(tmp_path):
    tree = load_tree(write(tmp_path / "t.yaml", COLLIDE), overrides=[POST])
    result = run(tree, record=tmp_path / "run")
    assert result.status == "FAILURE" and result.exit_code == 1
    assert result.message == "collision: tool hit post (11.6 mm deep) while Root/Swing ran"
    assert result.verdict == "failure"
    log, record = result_record(tmp_path / "run")
    (hit,) = [r for r in log if r.get("event") == "collision"]
    assert (hit["link"], hit["other"]) == ("tool", "post") and hit["depth_mm"] > 3
    assert hit["tick"] == record["tick"], "logged at the tick it happened, which ended the run"
    assert hit["t"] == pytest.approx(hit["time"])
    assert record["events"] == [
        {
            "tick": hit["tick"],
            "t": hit["t"],
            "event": "collision",
            "message": "collision: tool hit post 11.6 mm deep",
        }
    ]
    assert not [
        r
        for r in log
        if r["kind"] == "status" and r["node"] == "Root/Swing" and r["to"] == "SUCCESS"
    ]


def test_without_halt_on_collision_the_run_goes_on_and_the_collision_is_a_false_success(tmp_path):
    tree = load_tree(
        write(tmp_path / "t.yaml", COLLIDE),
        overrides=[POST, "world.physics.halt_on_collision=false"],
    )
    result = run(tree, record=tmp_path / "run")
    assert result.status == "SUCCESS" and result.verdict == "false success"
    assert result.exit_code == 1
    assert "collisions <= 0 (1 collision: tool hit post" in result.message
    log, _ = result_record(tmp_path / "run")
    assert [r["other"] for r in log if r.get("event") == "collision"] == ["post"]


REASONS = '''
import armtree
from armtree import Param
from py_trees.common import Status


class FailBecause(armtree.Behaviour):
    """Fails with a reason, after ``succeed_after`` failures succeeds (-1: never)."""

    PARAMS = (Param("reason", "str"), Param("succeed_after", "int", -1))

    def setup(self, **kwargs):
        super().setup(**kwargs)
        self.failures = 0

    def update(self):
        after = self.param("succeed_after")
        if after >= 0 and self.failures >= after:
            self.feedback_message = "fine now"
            return Status.SUCCESS
        self.failures += 1
        self.feedback_message = self.param("reason")
        return Status.FAILURE


@armtree.hookimpl
def armtree_behaviours():
    return {"fail_because": FailBecause}
'''


def test_every_failure_is_logged_with_its_reason_and_the_summary_chains_them(tmp_path):
    write(tmp_path / "reasons.py", REASONS)
    tree = load_tree(
        write(
            tmp_path / "t.yaml",
            """\
            plugins: [reasons.py]
            root:
              sequence:
                name: Task
                children:
                  - retry:
                      name: Twice
                      num_failures: 2
                      child: {fail_because: {name: Pick, reason: no ducky seen, succeed_after: 1}}
                  - selector:
                      name: Either
                      children:
                        - fail_because: {name: Look, reason: nothing in view 3 times}
                        - success: {name: Fallback}
                  - fail_because: {name: Place, reason: the Duckybot left}
            """,
        )
    )
    result = run(tree, record=tmp_path / "run")
    assert result.status == "FAILURE" and result.verdict == "failure"
    assert [(f.path, f.reason) for f in result.chain] == [
        ("Task", ""),
        ("Task/Place", "the Duckybot left"),
    ]
    assert [[(f.path, f.reason) for f in c] for c in result.absorbed] == [
        [("Task/Twice/Pick", "no ducky seen")],
        [("Task/Either/Look", "nothing in view 3 times")],
    ]
    log, record = result_record(tmp_path / "run")
    failures = [
        (r["node"], r["why"]) for r in log if r["kind"] == "status" and r["to"] == "FAILURE"
    ]
    assert failures == [
        ("Task/Twice/Pick", "no ducky seen"),
        ("Task/Either/Look", "nothing in view 3 times"),
        ("Task/Place", "the Duckybot left"),
        ("Task", "'Place' failed: the Duckybot left"),  # a sequence says which child failed
    ]
    assert not [r for r in log if r["kind"] == "status" and r["to"] != "FAILURE" and "why" in r]
    assert record["chain"][-1] == {
        "tick": 2,
        "t": 0.05,
        "node": "Task/Place",
        "why": "the Duckybot left",
    }
    from armtree.runtime.display import summary

    text = summary(result)
    assert "chain: Task > Place: the Duckybot left" in text
    assert "absorbed: t=0.00s Pick: no ducky seen" in text
    assert "absorbed: t=0.05s Look: nothing in view 3 times" in text


# -- the world's events ---------------------------------------------------------------

PROFILE = {
    "tracker": {"type": "aruco", "dictionary": "4x4_50"},
    "tags": {"trash": {"ids": [2, 3], "size_mm": 25}},
    "world": {
        "table": {"x": [-300, 400], "y": [-400, 400]},
        "objects": {
            "trash": {"kind": "trash", "at": [150, 150]},
            "bin": {"kind": "bin", "at": [0, 250], "size": [90, 90, 35]},
        },
    },
}


def lift_and_let_go(over, height):
    """Pick the trash by suction, carry it over ``over`` at ``height`` and let go."""
    world = World(parse_scene(PROFILE), seed=1)
    seen = []
    world.listeners.append(seen.append)
    emu = FakeEmulator()
    world.attach_arm(emu)
    trash = world.bodies["trash"]
    emu.put([150, 150, trash.top])
    emu.suction = True
    world.step(0.05)
    assert world.held == "trash"
    emu.put([*over, height])
    world.step(0.1)
    emu.suction = False
    world.step(0.15)
    world.settle()
    return world, [(e.kind, e.detail) for e in seen]


def test_a_high_release_outside_a_bin_is_a_drop_and_settle_lets_it_land():
    world, events = lift_and_let_go((150, -150), 80)
    kinds = [k for k, _ in events]
    assert kinds == ["pick", "release", "land", "drop"]
    drop = events[-1][1]
    assert drop["object"] == "trash" and drop["on"] == "table"
    assert drop["fall_mm"] == pytest.approx(80 - world.bodies["trash"].size[2], abs=0.5)
    assert not world.bodies["trash"].falling


def test_a_fall_into_a_bin_is_not_a_drop():
    world, events = lift_and_let_go((0, 250), 120)
    assert [k for k, _ in events] == ["pick", "release", "land"]
    assert world.in_bin(world.bodies["trash"]) == "bin"


def test_sort_that_could_not_put_an_object_away_fails_instead_of_a_false_success(tmp_path, capsys):
    # Seed 11 on sim_dobot: the bin has no room within reach for the third trash, the
    # absorbed put leaves it in the tool, and the sweep then covers the region.
    tree = "sort.yaml"
    args = [tree, "--rig", "sim_dobot", "--seed", "11", "--quiet"]
    code = run_tree_main([*args, "--record", str(tmp_path / "run")])
    out = capsys.readouterr().out
    assert code == 1
    assert out.splitlines()[0] == "result: FAILURE  (exit 1)"
    assert "FALSE SUCCESS" not in out
    assert "failed at Sort/Nothing left in hand" in out
