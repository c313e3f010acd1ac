"""Checks at load: components that miss their interface are refused, naming plugin, member and
what was expected; `armtree plugins --check`; plugins that declare the armtree versions they support."""

from __future__ import annotations

import textwrap
import types
from pathlib import Path

import numpy as np
import py_trees
import pytest

import armtree
from armtree.cli.commandline import main
from armtree.hooks import builtin_behaviours
from armtree.hooks.plugin_checks import installed_version, model_problems, version_problem
from armtree.hooks.plugin_manager import PluginManager
from armtree.maths.motion.kinematics import Joint, KinematicModel, LinkBox


def manager(*plugins: object) -> PluginManager:
    manager = PluginManager(autoload=False)
    manager.register(builtin_behaviours, "core_behaviours")
    for i, plugin in enumerate(plugins):
        manager.register(plugin, f"p{i}")
    return manager


def refusals(**components: object) -> list[str]:
    """The messages of building a registry holding ``components`` ({kind: {name: factory}})."""
    plugin = types.SimpleNamespace(
        **{f"armtree_{hook}": (lambda value=value: value) for hook, value in components.items()}
    )
    with pytest.raises(armtree.ConfigError) as info:
        manager(plugin).registry  # noqa: B018 - building the registry is what refuses
    return [e.message for e in info.value.errors]


class WrongUpdate(armtree.Behaviour):
    def update(self, blackboard):
        return None


class Updates(armtree.Behaviour):
    """Defines update(), so each class below misses its interface in one way only."""

    def update(self):
        return py_trees.common.Status.SUCCESS


class NotParams(Updates):
    PARAMS = ({"name": "speed", "type": "float"},)


class NoKwargsSetup(Updates):
    def setup(self, timeout):
        return None


class NarrowInit(Updates):
    PARAMS = (armtree.Param("speed", "float", 1.0),)

    def __init__(self, name):
        super().__init__(name)


class NotABehaviour:
    def update(self):
        return None


@pytest.mark.parametrize(
    ("factory", "member", "expected"),
    [
        (WrongUpdate, "update()", "expected update(self) -> py_trees.common.Status"),
        (NotParams, "PARAMS[0]", "expected a tuple of armtree.Param(name, type, default"),
        (NoKwargsSetup, "setup()", "expected setup(self, **kwargs)"),
        (NarrowInit, "__init__", "taking every parameter of PARAMS by keyword"),
        (NotABehaviour, "class", "expected a subclass of py_trees.behaviour.Behaviour"),
    ],
)
def test_a_behaviour_that_misses_its_interface_is_refused(factory, member, expected):
    (message,) = refusals(behaviours={"bad": factory})
    assert message.startswith(f"plugin 'p0': behaviour 'bad': {member}: "), message
    assert expected in message and "-p no:p0" in message


def arm_factory(config):  # one argument: the rig builder passes two
    return None


def good_arm(config, context):
    return None


good_arm.model = "not callable"


def planner(config, context):
    return None


class NoRun:
    help = "does nothing"

    def configure(self, parser):
        return None


def test_every_refusal_of_a_plugin_is_reported_at_once():
    messages = refusals(
        arms={"one_arg": arm_factory, "bad_model": good_arm},
        planners={"two_args": planner},
        commands={"norun": NoRun()},
    )
    assert any(
        m.startswith("plugin 'p0': arm 'one_arg': factory: signature arm_factory(config)")
        and "expected factory(config, context) -> ArmDriver" in m
        for m in messages
    ), messages
    assert any("arm 'bad_model': factory.model: str" in m for m in messages), messages
    assert any(
        "planner 'two_args'" in m and "factory(config, context, model, scene)" in m
        for m in messages
    ), messages
    assert any("command 'norun': run: missing; expected run(args) -> int" in m for m in messages)
    assert len(messages) == 4


def test_a_refusal_points_at_the_member_in_the_plugin_source(tmp_path, capsys):
    plugin = tmp_path / "broken.py"
    plugin.write_text(
        textwrap.dedent(
            """
            import armtree


            class Wave(armtree.Behaviour):
                \"\"\"Waves.\"\"\"

                def update(self, speed):
                    return None


            @armtree.hookimpl
            def armtree_behaviours():
                return {"wave": Wave}
            """
        )
    )
    code = main(["--plugin", str(plugin), "plugins", "--check"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith(f"{plugin}:8: plugin 'broken': behaviour 'wave': update(): "), err
    assert "expected update(self) -> py_trees.common.Status" in err and "Traceback" not in err


def test_the_shipped_plugins_pass_every_check(capsys):
    code = main(["plugins", "--check"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "ok: every component fits its interface" in out
    assert f"armtree {installed_version()}: checked" in out


class Lopsided(KinematicModel):
    """Two revolute joints; one box on a frame the arm does not have."""

    name = "lopsided"

    def __init__(self, home=(0.0, 0.0), ik_offset=0.0):
        self.joints = (Joint("a", "revolute", -90, 90), Joint("b", "revolute", -90, 90))
        self.home = np.array(home)
        self.boxes = (LinkBox("upper", 1, (10.0, 10.0, 10.0)), LinkBox("ghost", 7, (1.0, 1.0, 1.0)))
        self.ik_offset = ik_offset

    def link_frames(self, q):
        q = np.asarray(q, dtype=float)
        frames = np.broadcast_to(np.eye(4), (*q.shape[:-1], 3, 4, 4)).copy()
        frames[..., 1, 0, 3] = 100 * np.cos(np.radians(q[..., 0]))
        frames[..., 2, 0, 3] = 100 * np.cos(np.radians(q[..., 0])) + 50 * np.cos(
            np.radians(q[..., 1])
        )
        return frames

    def ik_all(self, target):
        return np.array([[self.ik_offset, self.ik_offset]])


def test_the_deep_check_finds_what_planners_and_the_sim_would_trip_on():
    found = {member: (seen, expected) for member, seen, expected in model_problems(Lopsided())}
    assert found["boxes[1] ghost"] == ("link 7", "a frame index below 3")
    assert "ik_all(position(home))" not in found
    found = dict((m, s) for m, s, _ in model_problems(Lopsided(home=(120.0, 0.0), ik_offset=60)))
    assert found["home"] == "[120.0, 0.0] outside the limits or constraints"
    assert found["ik_all(position(home))"].startswith("solutions reaching [75.0, 0.0, 0.0] mm")


def test_plugins_check_exits_2_on_a_broken_arm_model(tmp_path, capsys):
    plugin = tmp_path / "lopsided_arm.py"
    plugin.write_text(
        textwrap.dedent(
            f"""
            import armtree
            import sys
            sys.path.insert(0, {str(Path(__file__).parent)!r})
            from test_plugins_checks import Lopsided


            def lopsided(config, context):
                raise NotImplementedError


            lopsided.model = lambda config: Lopsided()


            @armtree.hookimpl
            def armtree_arms():
                return {{"lopsided": lopsided}}
            """
        )
    )
    code = main(["--plugin", str(plugin), "plugins", "--check", "--kind", "arm"])
    out = capsys.readouterr().out
    assert code == 2
    assert "plugin 'lopsided_arm': arm 'lopsided': boxes[1] ghost: link 7" in out
    assert "1 problem(s) found" in out


def test_a_plugin_naming_other_armtree_versions_is_refused_naming_both():
    plugin = types.ModuleType("future_plugin")
    plugin.ARMTREE_REQUIRES = ">=9.0"
    error = version_problem(plugin, "future", None)
    assert error is not None
    assert (
        f"plugin 'future' supports armtree >=9.0 (ARMTREE_REQUIRES = '>=9.0'), but armtree {installed_version()} is installed"
        in error.message
    )
    assert "-p no:future" in error.message
    with pytest.raises(armtree.ConfigError, match="supports armtree >=9.0"):
        manager().register(plugin, "future")
    plugin.ARMTREE_REQUIRES = f"=={installed_version()}"
    assert version_problem(plugin, "future", None) is None
    plugin.ARMTREE_REQUIRES = "0.1 or later"
    assert "is not a version specifier" in version_problem(plugin, "future", None).message


def test_a_distribution_requiring_another_armtree_is_refused(tmp_path, monkeypatch):
    info = tmp_path / "armtree_future-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: armtree-future\nVersion: 1.0\n"
        "Requires-Dist: numpy\nRequires-Dist: armtree<0.1\n"
        'Requires-Dist: armtree>=99; extra == "docs"\n'
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    error = version_problem(types.ModuleType("m"), "future", "armtree-future")
    assert error is not None
    assert "plugin 'future' (distribution armtree-future) supports armtree <0.1" in error.message
    assert f"but armtree {installed_version()} is installed" in error.message
