"""Building the rig from a profile through the plugin registry, and runs that build their own."""

import json

import py_trees
import pytest
from py_trees.common import Status

import armtree
from armtree.api.clock import VirtualClock, WallClock
from armtree.errors import ConfigError, HardwareFault
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.tree import Tree
from armtree.runtime.rig_builder import build_rig, make_scene, parse_tags, uses_real_hardware
from armtree.runtime.runner import Run, run

PROFILE = {
    "profile": "fake",
    "arm": {"type": "fake_arm", "port": "sim", "speed": 2},
    "camera": {"type": "fake_cam", "port": "sim", "width": 64},
    "tracker": {"type": "fake_tracker"},
    "planner": {"type": "fake_planner", "milestones": 10},
    "tags": {"ducky": {"id": 0, "size_mm": 25}, "trash": {"ids": [2, 3], "size_mm": 20}},
    "places": {"home": [200, 0, 80]},
    "obstacles": [],
}


class FakePlugin:
    """Records what the builder does, in order."""

    def __init__(
        self, fail_camera=False, interrupt_at=None, fail_connect=False, fail_camera_start=False
    ):
        self.events = []
        self.fail_camera = fail_camera
        self.fail_camera_start = fail_camera_start
        self.fail_connect = fail_connect
        self.interrupt_at = interrupt_at
        self.args = {}

    def arm(self, config, context):
        self.args["arm"] = (config, context)
        context.closers.append(lambda: self.events.append("emulator closed"))

        def stepper(now):
            self.events.append(("step", now))
            if self.interrupt_at is not None and now >= self.interrupt_at:
                context.interrupt("e-stop", HardwareFault("e-stop pressed", "sim"))

        context.steppers.append(stepper)
        plugin = self

        class Arm:
            model = "the arm model"

            def connect(self):
                if plugin.fail_connect:
                    raise HardwareFault("no such serial port", "/dev/ttyUSB9")
                plugin.events.append("arm connected")

            def stop(self):
                plugin.events.append("arm stopped")

            def close(self):
                plugin.events.append("arm closed")

        self.events.append("arm built")
        return Arm()

    def camera(self, config, context):
        if self.fail_camera:
            raise HardwareFault("cannot open camera", "/dev/video0")
        plugin = self

        class Cam:
            def start(self):
                if plugin.fail_camera_start:
                    raise HardwareFault("cannot open camera index 3", "3")
                plugin.events.append("camera started")

            def close(self):
                plugin.events.append("camera closed")

        self.events.append("camera built")
        return Cam()

    def tracker(self, config, context):
        self.events.append("tracker built")
        return "tracker"

    def planner(self, config, context, model, scene):
        self.args["planner"] = (config, model, scene)
        self.events.append("planner built")
        return "planner"

    @armtree.hookimpl
    def armtree_arms(self):
        return {"fake_arm": on_no_device(self.arm)}

    @armtree.hookimpl
    def armtree_cameras(self):
        return {"fake_cam": on_no_device(self.camera)}

    @armtree.hookimpl
    def armtree_trackers(self):
        return {"fake_tracker": self.tracker}

    @armtree.hookimpl
    def armtree_planners(self):
        return {"fake_planner": self.planner}

    @armtree.hookimpl
    def armtree_rig_ready(self, rig, context):
        self.events.append(("rig ready", rig.arm is not None, rig.planner))


def on_no_device(method):
    """``method`` as a factory that says it drives no device (the run keeps a virtual clock)."""

    def factory(config, context):
        return method(config, context)

    factory.simulated = lambda config: True
    return factory


def manager_with(plugin):
    manager = PluginManager(autoload=False)
    manager.register(plugin, "fake")
    return manager


def test_build_rig_builds_components_in_order_and_wires_them():
    plugin = FakePlugin()
    clock = VirtualClock()
    rig = build_rig(PROFILE, manager_with(plugin), clock, seed=7)
    assert plugin.events == [
        "arm built",
        "camera built",
        "tracker built",
        "planner built",
        ("rig ready", True, "planner"),
        "arm connected",
        "camera started",
    ]
    config, context = plugin.args["arm"]
    assert config == PROFILE["arm"] and context.seed == 7 and context.clock is clock
    planner_config, model, scene = plugin.args["planner"]
    assert planner_config["milestones"] == 10 and model == "the arm model"
    assert scene is not None
    assert rig.tracker == "tracker" and rig.places == {"home": [200, 0, 80]}
    assert rig.tags["trash"].ids == (2, 3) and rig.role_of(3).role == "trash"
    rig.step(0.5)
    assert plugin.events[-1] == ("step", 0.5)
    rig.close()
    assert plugin.events[-4:] == ["arm stopped", "camera closed", "arm closed", "emulator closed"]


def test_unknown_component_type_is_a_config_error_with_a_suggestion():
    profile = dict(PROFILE, arm={"type": "fake_army", "port": "sim"})
    with pytest.raises(ConfigError, match="did you mean 'fake_arm'"):
        build_rig(profile, manager_with(FakePlugin()), VirtualClock())


def test_a_failing_factory_closes_what_was_built_and_raises_the_fault():
    plugin = FakePlugin(fail_camera=True)
    with pytest.raises(HardwareFault, match="/dev/video0"):
        build_rig(PROFILE, manager_with(plugin), VirtualClock())
    assert plugin.events == ["arm built", "arm stopped", "arm closed", "emulator closed"]


def test_real_hardware_is_what_the_arm_and_camera_factories_say():
    assert not uses_real_hardware({"arm": {"type": "dobot_v1", "port": "sim"}})
    assert uses_real_hardware({"arm": {"type": "dobot_v1", "port": "/dev/ttyUSB0"}})
    assert uses_real_hardware(
        {"arm": {"type": "dobot_v1", "port": "sim"}, "camera": {"type": "opencv", "index": 0}}
    )
    assert not uses_real_hardware({"arm": {"type": "vicra"}, "camera": {"type": "sim"}})

    # a factory that does not say is a device when it names a port, whatever the port
    class Silent:
        @armtree.hookimpl
        def armtree_arms(self):
            return {"silent_arm": lambda config, context: None}

    registry = manager_with(Silent()).registry
    assert uses_real_hardware({"arm": {"type": "silent_arm", "port": "sim"}}, registry)
    assert not uses_real_hardware({"arm": {"type": "silent_arm"}}, registry)


def test_tags_accept_id_or_ids_and_need_a_size():
    tags = parse_tags({"a": {"id": 4, "size_mm": 30}, "b": {"ids": [1, 2], "size_mm": 25}})
    assert tags["a"].ids == (4,) and tags["b"].size_mm == 25.0
    with pytest.raises(ConfigError):
        parse_tags({"a": {"id": 4}})


def test_scene_falls_back_to_the_raw_obstacles_only_without_armtree_scene():
    scene = make_scene({"obstacles": []})
    try:
        from armtree.maths.motion.scene import Scene
    except ImportError:
        assert scene == []
    else:
        assert isinstance(scene, Scene)


def test_a_run_builds_its_own_rig_on_a_virtual_clock_and_closes_it():
    plugin = FakePlugin()
    node = py_trees.behaviours.TickCounter(name="c", duration=2, completion_status=Status.SUCCESS)
    tree = Tree(name="t", root=node, source=None, profile=PROFILE)
    r = Run(tree, manager=manager_with(plugin), record=False)
    assert isinstance(r.clock, VirtualClock)
    result = r.execute()
    assert result.status == "SUCCESS"
    steps = [e[1] for e in plugin.events if isinstance(e, tuple) and e[0] == "step"]
    assert steps == pytest.approx([0.0, 0.05, 0.1], abs=1e-12)
    assert plugin.events[-3:] == ["camera closed", "arm closed", "emulator closed"]


def test_a_component_interrupt_through_the_context_exits_3():
    plugin = FakePlugin(interrupt_at=0.1)
    tree = Tree(name="t", root=py_trees.behaviours.Running("spin"), source=None, profile=PROFILE)
    result = run(tree, manager=manager_with(plugin), record=False)
    assert result.status == "INTERRUPTED" and result.exit_code == 3
    assert result.ticks == 3 and "e-stop pressed" in result.message
    assert "arm stopped" in plugin.events and plugin.events[-1] == "emulator closed"


def test_a_real_hardware_profile_runs_on_the_wall_clock():
    profile = dict(PROFILE, arm={"type": "fake_arm", "port": "/dev/ttyUSB0"})
    tree = Tree(name="t", root=py_trees.behaviours.Success("s"), source=None, profile=profile)
    assert isinstance(Run(tree, record=False).clock, WallClock)


def test_a_run_whose_arm_does_not_connect_fails_with_exit_3_before_any_tick():
    plugin = FakePlugin(fail_connect=True)
    node = py_trees.behaviours.Running("spin")
    tree = Tree(name="t", root=node, source=None, profile=PROFILE)
    result = run(tree, manager=manager_with(plugin), record=False)
    assert result.status == "FAILURE" and result.exit_code == 3 and result.ticks == 0
    assert "/dev/ttyUSB9: no such serial port" in result.message
    assert plugin.events[-3:] == ["camera closed", "arm closed", "emulator closed"]
    assert node.status == Status.INVALID


def test_a_fault_while_starting_closes_what_started_in_reverse_order():
    plugin = FakePlugin(fail_camera_start=True)
    with pytest.raises(HardwareFault, match="camera index 3"):
        build_rig(PROFILE, manager_with(plugin), VirtualClock())
    i = plugin.events.index("arm connected")
    assert plugin.events[i:] == [
        "arm connected",
        "arm stopped",
        "camera closed",
        "arm closed",
        "emulator closed",
    ]


class Boom(py_trees.behaviour.Behaviour):
    def update(self):
        raise RuntimeError("boom")


@pytest.mark.parametrize(
    ("root", "status", "code"),
    [
        (lambda: py_trees.behaviours.Success("s"), "SUCCESS", 0),
        (lambda: py_trees.behaviours.Failure("f"), "FAILURE", 1),
        (lambda: Boom("boom"), "FAILURE", 1),
    ],
    ids=["success", "failure", "exception"],
)
def test_every_end_of_a_run_stops_the_components_in_reverse_start_order(root, status, code):
    plugin = FakePlugin()
    tree = Tree(name="t", root=root(), source=None, profile=PROFILE)
    result = run(tree, manager=manager_with(plugin), record=False)
    assert (result.status, result.exit_code) == (status, code)
    started = plugin.events.index("camera started")
    assert plugin.events.index("arm connected") < started
    closes = [e for e in plugin.events if e in ("camera closed", "arm closed", "emulator closed")]
    assert closes == ["camera closed", "arm closed", "emulator closed"]


def test_a_wall_clock_run_reports_how_late_its_ticks_started(tmp_path):
    node = py_trees.behaviours.TickCounter(name="c", duration=5, completion_status=Status.SUCCESS)
    tree = Tree(name="t", root=node, source=None, profile=None)
    r = Run(tree, realtime=True, record=tmp_path, handle_signals=False, stop_key=False)
    result = r.execute()
    assert result.status == "SUCCESS" and len(r.tick_lateness) == result.ticks == 6
    assert all(late > -0.005 for late in r.tick_lateness), "no tick starts early"
    assert "(p99)" in result.details["tick start"]
    record = [json.loads(line) for line in (tmp_path / "run.jsonl").read_text().splitlines()][-1]
    late = record["tick_lateness_ms"]
    assert late["ticks"] == 6 and 0.0 <= late["p50"] <= late["p99"] <= late["max"]
    assert result.seconds >= 5 * 0.05 - 1e-3, "ticks were paced on the wall clock"
