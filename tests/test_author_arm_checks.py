"""`armtree check` (and so `run-tree`, before anything moves) runs `armtree plugins --check`'s
checks on the arm the rig uses, built from the profile: a home outside the limits, an IK
with a sign error or a workspace that disagrees with the arm is the plugin's, at its line
(issue 29)."""

from __future__ import annotations

import pytest
from plugin_author import armtree, line_of, run_tree

from armtree.cli import commandline as cli
from armtree.config.resolve import available
from armtree.hooks.plugin_checks import model_problems, rig_problems
from armtree.loader.profile import load_profile
from armtree.plugins.arms.common.workspace_shapes import scara_shape
from armtree.plugins.arms.vicra.kinematics import VicraModel

#: Mistakes to make in the scaffolded arm's kinematics: (what is written, what instead,
#: the line the error names (its text), what the error says).
MISTAKES = {
    "home outside the limits": (
        "self.home = np.array([150.0, -45.0, 90.0])",
        "self.home = np.array([150.0, -45.0, 170.0])",
        "self.home = ",
        "home: [150.0, -45.0, 170.0] outside the limits or constraints; expected a pose the "
        "arm can take",
    ),
    "an IK sign error": (
        "t1 = np.arctan2(y, x) - np.arctan2(",
        "t1 = np.arctan2(y, x) + np.arctan2(",
        "def ik_all",
        "ik_all(position(home)): solutions reaching [0.0, 353.553, 150.0] mm, not "
        "[353.553, 0.0, 150.0]; expected fk(ik(p)) == p",
    ),
    "a mirrored IK": (  # right at home (y = 0), wrong everywhere else
        "t1 = np.arctan2(y, x) - np.arctan2(",
        "t1 = np.arctan2(-y, x) - np.arctan2(",
        "def ik_all",
        "ik_all(position(q)): solutions reaching",
    ),
    "a workspace for other links": (
        "return scara_shape(self, self.l1, self.l2)",
        "return scara_shape(self, self.l1, self.l2 - 100)",
        "def workspace_shape",
        "workspace_shape(): the tool at",
    ),
}


@pytest.fixture(scope="module")
def scaffolded(tmp_path_factory):
    """The `arm` kind of `armtree new-plugin`, written once for this module's tests."""
    root = tmp_path_factory.mktemp("arm")
    assert cli.main(["new-plugin", "cheapo", "--kind", "arm", "--dir", str(root)]) == 0
    package = root / "armtree-cheapo"
    return package, (package / "src" / "armtree_cheapo" / "kinematics.py").read_text()


@pytest.mark.slow  # two or three commands on a simulated rig each
@pytest.mark.parametrize("mistake", sorted(MISTAKES))
def test_check_and_run_tree_refuse_an_arm_plugins_mistake_at_its_line(scaffolded, mistake):
    package, original = scaffolded
    written, instead, at, said = MISTAKES[mistake]
    kinematics = package / "src" / "armtree_cheapo" / "kinematics.py"
    assert written in original
    kinematics.write_text(original.replace(written, instead))
    try:
        options = ("--plugin", "armtree_cheapo.plugin")
        env = {"PYTHONPATH": str(package / "src")}
        checked = armtree(package, "check", "trees/cheapo_demo.yaml", *options, env=env)
        assert checked.returncode == 2, checked.stdout + checked.stderr
        first = checked.stderr.splitlines()[0]
        assert first.startswith(
            f"{kinematics}:{line_of(kinematics, at)}: plugin 'armtree_cheapo.plugin': arm "
            f"'cheapo': {said}"
        ), checked.stderr
        assert "(the model built from the profile's arm: at " in first
        assert "sim_cheapo.yaml:5:" in first
        ran = run_tree(package, "trees/cheapo_demo.yaml", "--quiet", *options, env=env)
        assert ran.returncode == 2 and ran.stderr.splitlines()[0] == first
        assert "result:" not in ran.stdout  # nothing ran
        if "IK" in mistake:  # the same check as plugins --check's
            listed = armtree(package, "plugins", "--check", "--kind", "arm", *options, env=env)
            assert listed.returncode == 2 and said in listed.stdout
    finally:
        kinematics.write_text(original)


@pytest.mark.parametrize("name", sorted(available("profile")))
def test_every_shipped_profiles_arm_passes_them(name):
    assert [e.message for e in rig_problems(load_profile(name))] == []


def test_a_workspace_that_disagrees_with_the_arm_is_found():
    class Misdescribed(VicraModel):
        def workspace_shape(self):
            return scara_shape(self, self.l1, self.l2 / 2)

    assert model_problems(VicraModel()) == []
    problems = model_problems(Misdescribed())
    assert [member for member, _, _ in problems] == ["workspace_shape()"]
    assert "within the limits) outside it" in problems[0][1]


def test_an_arm_factory_that_raises_is_named_at_its_line_before_anything_moves(scaffolded):
    package, _ = scaffolded
    plugin = package / "src" / "armtree_cheapo" / "plugin.py"
    original = plugin.read_text()
    written = '    """The Cheapo SCARA arm with a suction cup; ``port: sim`` runs its firmware emulator."""\n'
    assert written in original
    plugin.write_text(original.replace(written, written + '    raise KeyError("calibration")\n'))
    try:
        options = ("--plugin", "armtree_cheapo.plugin", "--quiet")
        env = {"PYTHONPATH": str(package / "src")}
        ran = run_tree(package, "trees/cheapo_demo.yaml", *options, env=env)
        assert ran.returncode == 2, ran.stdout + ran.stderr
        line = line_of(plugin, 'raise KeyError("calibration")')
        first = ran.stderr.splitlines()[0]
        assert first.startswith(f"{plugin}:{line}: arm 'cheapo' (named at "), first
        assert "sim_cheapo.yaml:5:" in first
        assert (
            "its factory (plugin 'armtree_cheapo.plugin') raised KeyError: 'calibration'" in first
        )
        assert "Traceback" not in ran.stderr and "result:" not in ran.stdout
        debug = run_tree(package, "trees/cheapo_demo.yaml", *options, "--debug", env=env)
        assert debug.returncode == 2 and "Traceback (most recent call last)" in debug.stderr
    finally:
        plugin.write_text(original)
