"""Hardware profiles: loading, overrides and every validation error at its position."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

import armtree
from armtree.api.rig import TagSpec
from armtree.config.params import Param
from armtree.config.profile_sections import ProfileSection
from armtree.hooks import builtin_behaviours
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.profile import parse_override


def _factory(doc: str, params: tuple[Param, ...] = (), planner: bool = False):
    def factory(config, context):
        return config

    if planner:  # the rig builder gives a planner factory the arm's model and the scene too

        def factory(config, context, model, scene):  # noqa: F811
            return config

    factory.__doc__ = doc
    factory.PARAMS = params
    return factory


class FakeComponents:
    """Registers component types under the names the shipped profiles use."""

    @armtree.hookimpl
    def armtree_arms(self):
        arm = _factory(
            "A checked arm.",
            (
                Param("port", "str", doc="serial device or sim"),
                Param("baud", "int", 9600),
                Param("firmware", "str", "original", choices=("original", "open")),
                Param("tool_offset_mm", "float", 0.0, unit="mm"),
            ),
        )
        return {"dobot_v1": arm, "vicra": _factory("An unchecked arm.")}

    @armtree.hookimpl
    def armtree_cameras(self):
        return {"sim": _factory("A camera.")}

    @armtree.hookimpl
    def armtree_trackers(self):
        return {"aruco": _factory("A tracker.")}

    @armtree.hookimpl
    def armtree_planners(self):
        return {
            "prm": _factory("A planner.", planner=True),
            "direct": _factory("Straight lines.", planner=True),
        }

    @armtree.hookimpl
    def armtree_profile_sections(self):
        return {"world": ProfileSection(schema={"type": "object", "description": "a world"})}


def manager() -> PluginManager:
    m = PluginManager(autoload=False)
    m.register(builtin_behaviours, "core_behaviours")
    m.register(FakeComponents(), "fake_components")
    return m


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return path


GOOD = """
profile: bench
arm: {type: dobot_v1, port: sim}
camera: {type: sim, width: 640}
tags:
  ducky: {id: 0, size_mm: 25}
  trash: {ids: [2, 3], size_mm: 30.5}
places:
  home: [200, 0, 80]
obstacles:
  - box: {center: [0, 0, -5], size: [400, 400, 10]}
world: {seed: 3}
"""


def test_shipped_profiles_load_by_name():
    for name in ("sim_dobot", "sim_vicra.yaml"):
        profile = armtree.load_profile(name, manager=manager())
        assert profile.source.parent.name == "hardware"
        assert profile.data["arm"]["port"] == "sim"
        trash = TagSpec("trash", (2, 3, 4), 25.0, {"hamming": (70026, 70124, 70419)})
        assert profile.tags()["trash"] == trash
        assert set(profile.places()) >= {"home", "ducky_pickup", "garbage_bin"}


def test_profile_fields_helpers_and_marks(tmp_path):
    path = write(tmp_path, "bench.yaml", GOOD)
    profile = armtree.load_profile(path, manager=manager())
    assert profile.name == "bench" and profile.source == path.resolve()
    assert profile.tags() == {
        "ducky": TagSpec("ducky", (0,), 25.0),
        "trash": TagSpec("trash", (2, 3), 30.5),
    }
    assert profile.places() == {"home": [200.0, 0.0, 80.0]}
    assert profile.obstacles() == [{"box": {"center": [0, 0, -5], "size": [400, 400, 10]}}]
    assert profile.component("arm") == {
        "type": "dobot_v1",
        "port": "sim",
        "baud": 9600,
        "firmware": "original",
        "tool_offset_mm": 0.0,
    }
    assert profile.component("planner") is None
    mark = profile.mark("arm.port")
    assert (mark.line, mark.column) == (2, 29)
    err = profile.error("tags.trash.ids", "id 3 is not printed")
    assert (err.file, err.line, err.column) == (str(path.resolve()), 6, 16)
    assert err.message == "tags.trash.ids: id 3 is not printed"


PROFILE_CASES = [
    (
        "arm: {type: dobot_v1, port: sim}\ncamra: {type: sim}\n",
        (2, 1),
        "unknown profile section 'camra'; did you mean 'camera'?",
    ),
    ("camera: {type: sim}\n", (1, 1), "the profile has no 'arm' section"),
    (
        "arm: {type: dobot_v2, port: sim}\n",
        (1, 13),
        "arm: unknown arm type 'dobot_v2'; did you mean 'dobot_v1'?",
    ),
    ("arm: {port: sim}\n", (1, 6), "arm: needs a type (one of: dobot_v1, vicra)"),
    ("arm: dobot_v1\n", (1, 6), "arm: expected a mapping with a type"),
    (
        "arm: {type: dobot_v1, port: sim, baudrate: 1}\n",
        (1, 34),
        "arm: dobot_v1 has no parameter 'baudrate'; did you mean 'baud'?",
    ),
    (
        "arm: {type: dobot_v1, port: sim, baud: fast}\n",
        (1, 40),
        "arm.baud: expected an integer, got a string 'fast'",
    ),
    (
        "arm: {type: dobot_v1, port: sim, firmware: new}\n",
        (1, 44),
        "arm.firmware: 'new' is not one of 'original', 'open'",
    ),
    (
        "arm: {type: dobot_v1}\n",
        (1, 6),
        "arm: dobot_v1 needs parameter 'port' (serial device or sim)",
    ),
    (
        "arm: {type: vicra, anything: 1}\ntracker: {type: arcuo}\n",
        (2, 17),
        "tracker: unknown tracker type 'arcuo'; did you mean 'aruco'?",
    ),
    (
        "arm: {type: vicra}\ntags: {a: {id: 1, ids: [2], size_mm: 5}}\n",
        (2, 11),
        "tags.a: give either id or ids",
    ),
    (
        "arm: {type: vicra}\ntags: {a: {id: -1, size_mm: 5}}\n",
        (2, 16),
        "tags.a.id: expected a marker id >= 0",
    ),
    (
        "arm: {type: vicra}\ntags: {a: {id: 1, size_mm: 0}}\n",
        (2, 28),
        "tags.a.size_mm: expected a number > 0 (mm), got 0",
    ),
    ("arm: {type: vicra}\ntags: {a: {id: 1}}\n", (2, 11), "tags.a: needs size_mm"),
    (
        "arm: {type: vicra}\ntags: {a: {id: 1, size_mm: 5, colour: red}}\n",
        (2, 31),
        "tags.a: unknown key 'colour'",
    ),
    (
        "arm: {type: vicra}\ntags:\n  a: {id: 1, size_mm: 5}\n  b: {ids: [4, 1], size_mm: 5}\n",
        (4, 16),
        "tags.b: marker id 1 is already used by tag 'a'",
    ),
    (
        "arm: {type: vicra}\nplaces: {home: [1, 2]}\n",
        (2, 16),
        "places.home: expected [x, y, z] in mm",
    ),
    (
        "arm: {type: vicra}\nplaces: {home: [1, 2, .nan]}\n",
        (2, 16),
        "places.home: expected [x, y, z] in mm",
    ),
    ("arm: {type: vicra}\nobstacles: [{cone: {}}]\n", (2, 13), "obstacles[0]: expected one shape"),
    (
        "arm: {type: vicra}\nobstacles: [{box: {center: [0, 0, 0], size: [1, 0, 1]}}]\n",
        (2, 45),
        "obstacles[0].box.size: sizes must be > 0 mm",
    ),
    (
        "arm: {type: vicra}\nobstacles: [{box: {center: [0, 0, 0]}}]\n",
        (2, 19),
        "obstacles[0].box: needs size",
    ),
    ("arm: {type: vicra}\nobstacles: {box: {}}\n", (2, 12), "obstacles: expected a list of shapes"),
    ("arm: {type: vicra}\nworld: [1]\n", (2, 8), "world: expected a mapping"),
    ("arm: {type: vicra}\nplugins: not_a_list\n", (2, 10), "plugins: expected a list"),
    ("arm: {type: vicra\n", (2, 1), "invalid YAML"),
]


@pytest.mark.parametrize(
    ("text", "where", "message"), PROFILE_CASES, ids=[c[2][:40] for c in PROFILE_CASES]
)
def test_profile_error_at_its_position(tmp_path, text, where, message):
    path = write(tmp_path, "p.yaml", text)
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile(path, manager=manager())
    errors = info.value.errors
    assert len(errors) == 1, info.value.format()
    err = errors[0]
    assert (err.file, err.line, err.column) == (str(path.resolve()), *where), err.format()
    assert message in err.message


def test_all_profile_errors_at_once(tmp_path):
    path = write(
        tmp_path,
        "p.yaml",
        """
        arm: {type: dobot_v1, port: 3}
        camera: {type: webcam}
        tags: {a: {id: 1, size_mm: -2}, b: {id: 1, size_mm: 2}}
        places: {bin: [0, 0]}
        """,
    )
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile(path, manager=manager())
    assert [(e.line, e.column) for e in info.value.errors] == [
        (1, 29),
        (2, 16),
        (3, 28),
        (3, 41),
        (4, 15),
    ]


def test_overrides_are_dotted_and_yaml_typed(tmp_path):
    path = write(tmp_path, "bench.yaml", GOOD)
    profile = armtree.load_profile(
        path,
        ["arm.baud=115200", "camera.intrinsics.fx=800.5", "places.bin=[1, 2, 3]", "arm.type=vicra"],
        manager=manager(),
    )
    assert profile.data["arm"] == {"type": "vicra", "port": "sim", "baud": 115200}
    assert profile.data["camera"]["intrinsics"] == {"fx": 800.5}
    assert profile.places()["bin"] == [1.0, 2.0, 3.0]
    mark = profile.mark("arm.baud")
    assert mark.file == "--set arm.baud=115200"


def test_a_bad_override_value_is_reported_at_the_override(tmp_path):
    path = write(tmp_path, "bench.yaml", GOOD)
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile(path, ["arm.type=vicar", "arm.port.x=1", "oops"], manager=manager())
    messages = [e.format() for e in info.value.errors]
    assert "--set arm.type=vicar: arm: unknown arm type 'vicar'; did you mean 'vicra'?" in messages
    assert "--set arm.port.x=1: cannot set arm.port.x: arm.port is not a mapping" in messages
    assert any(m.startswith("--set: expected KEY=VALUE") for m in messages)


@pytest.mark.parametrize(
    ("text", "keys", "value"),
    [
        ("arm.type=vicra", ("arm", "type"), "vicra"),
        ("camera.width=800", ("camera", "width"), 800),
        ("world.faults=[cut, drop]", ("world", "faults"), ["cut", "drop"]),
        ("flag=true", ("flag",), True),
        ("note=a=b", ("note",), "a=b"),
        ("empty=", ("empty",), ""),
    ],
)
def test_parse_override(text, keys, value):
    override = parse_override(text)
    assert (override.keys, override.value) == (keys, value)


@pytest.mark.parametrize("text", ["noequals", "=3", "a..b=1", "a=[1, 2"])
def test_parse_override_rejects(text):
    with pytest.raises(armtree.ConfigError):
        parse_override(text)


def test_with_overrides_revalidates_a_loaded_profile(tmp_path):
    profile = armtree.load_profile(write(tmp_path, "bench.yaml", GOOD), manager=manager())
    changed = profile.with_overrides(["camera.width=1280"])
    assert changed.data["camera"]["width"] == 1280 and profile.data["camera"]["width"] == 640
    assert changed.mark("arm.port") == profile.mark("arm.port")
    with pytest.raises(armtree.ConfigError) as info:
        profile.with_overrides(["tags.ducky.size_mm=0"])
    assert info.value.file == "--set tags.ducky.size_mm=0"


def test_tree_passes_profile_overrides_and_reports_profile_errors(tmp_path):
    write(tmp_path, "bench.yaml", GOOD)
    tree_path = write(
        tmp_path, "t.yaml", "rig: bench\nblackboard: {goal: 0}\nroot: {success: {}}\n"
    )
    tree = armtree.load_tree(
        tree_path, overrides=["arm.port=/dev/ttyUSB0", "goal=1"], manager=manager()
    )
    assert tree.profile.data["arm"]["port"] == "/dev/ttyUSB0" and tree.blackboard == {"goal": 1}
    bad_tree = write(tmp_path, "bad.yaml", "rig: nowhere\nroot: {sucess: {}}\n")
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_tree(bad_tree, manager=manager())
    formatted = info.value.format().splitlines()
    assert formatted[0].startswith(f"{bad_tree.resolve()}:1:6: no hardware profile 'nowhere'")
    assert formatted[1].startswith(f"{bad_tree.resolve()}:2:8: unknown node type 'sucess'")
    other = armtree.load_tree(tree_path, rig=tmp_path / "bench.yaml", manager=manager())
    assert other.profile.name == "bench"


def test_unknown_profile_name_suggests_a_shipped_one():
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile("sim_dobbot", manager=manager())
    assert "did you mean 'sim_dobot'?" in info.value.message


def test_plugins_listed_in_a_profile_register_its_components(tmp_path):
    write(
        tmp_path,
        "custom_arm.py",
        '''
        import armtree


        def custom(config, context):
            """An arm from the profile's own plugin."""
            return config


        custom.PARAMS = (armtree.Param("port", "str"),)


        @armtree.hookimpl
        def armtree_arms():
            return {"custom_arm": custom}
        ''',
    )
    path = write(
        tmp_path, "p.yaml", "plugins: [custom_arm.py]\narm: {type: custom_arm, port: sim, x: 1}\n"
    )
    base = manager()
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile(path, manager=base)
    assert (info.value.line, info.value.column) == (2, 36)
    assert "custom_arm has no parameter 'x'" in info.value.message
    path.write_text("plugins: [custom_arm.py]\narm: {type: custom_arm, port: sim}\n")
    profile = armtree.load_profile(path, manager=manager())
    assert profile.plugins == [str(tmp_path / "custom_arm.py")]
    assert (
        profile.manager.registry.get("arm", "custom_arm").summary
        == "An arm from the profile's own plugin."
    )
    tree_path = write(tmp_path, "t.yaml", "rig: p.yaml\nroot: {success: {}}\n")
    tree = armtree.load_tree(tree_path, manager=manager())
    assert tree.manager.registry.has("arm", "custom_arm") and tree.profile.name == "p"
