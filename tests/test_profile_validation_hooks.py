"""Load-time checks beyond the profile's own: the planning scene, ``table:`` and plugins' hooks.

``armtree.load_profile`` builds the planning scene and calls every
``armtree_validate_profile`` hook and the checks of sections plugins own (the sim
plugin parses ``world:`` there), so
``armtree check`` refuses what building the rig would refuse, at the entry's
file, line and column, together with the profile's other errors.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from armtree.config.profile_sections import PROFILE_KEYS
from armtree.errors import ConfigError
from armtree.loader.profile import load_profile
from armtree.maths.motion.scene import Scene

# A simulated Dobot whose world and tags agree; each test breaks one line of it.
SIM = """\
profile: t
arm: {type: dobot_v1, port: sim}
tags:
  ducky: {id: 0, size_mm: 25}
  trash: {ids: [2, 3], size_mm: 25}
places:
  home: [185, 0, 30]
world:
  table: {x: [-250, 450], y: [-400, 400], height: -35}
  objects:
    ducky: {kind: ducky, at: [119, -142]}
    trash_a: {kind: trash, at: [92, 160]}
"""


def write(tmp_path: Path, text: str, name: str = "rig.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def position(path: Path, needle: str, column_of: str | None = None) -> tuple[int, int]:
    """1-based line of the first line containing ``needle`` and column of ``column_of`` in it."""
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if needle in line:
            return number, line.index(column_of or needle) + 1
    raise AssertionError(f"{needle!r} not in {path}")


def errors_of(path: Path, overrides: tuple[str, ...] = ()) -> list[ConfigError]:
    with pytest.raises(ConfigError) as info:
        load_profile(path, overrides)
    return info.value.errors


def test_a_consistent_sim_profile_loads(tmp_path):
    profile = load_profile(write(tmp_path, SIM))
    assert profile.invalid == frozenset()
    assert profile.places()["home"] == [185.0, 0.0, 30.0]


def test_armtree_check_refuses_overlapping_world_objects_at_the_entry(tmp_path):
    rig = write(tmp_path, SIM.replace("at: [92, 160]", "at: [125, -140]"))
    tree = write(tmp_path, "rig: rig.yaml\nroot:\n  success: {}\n", "tree.yaml")
    done = subprocess.run(
        [sys.executable, "-m", "armtree.cli", "check", str(tree)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    output = done.stdout + done.stderr
    assert done.returncode == 2, output
    line, column = position(rig, "trash_a:", "{kind")
    assert f"{rig}:{line}:{column}: world.objects.trash_a: trash_a overlaps ducky" in output
    assert "Traceback" not in output


def test_object_off_the_table_is_refused_at_load(tmp_path):
    rig = write(tmp_path, SIM.replace("at: [92, 160]", "at: [92, 395]"))
    (err,) = errors_of(rig)
    assert "off the table" in err.message and "trash_a" in err.message
    assert (err.line, err.column) == position(rig, "trash_a:", "{kind")


def test_world_marker_id_clashing_with_tags(tmp_path):
    rig = write(
        tmp_path,
        SIM.replace(
            "trash_a: {kind: trash, at: [92, 160]}",
            "trash_a: {kind: trash, at: [92, 160], marker: {id: 0}}",
        ),
    )
    (err,) = errors_of(rig)
    assert "world.objects.trash_a.marker.id" in err.message
    assert "marker id 0 is the 'ducky' tag" in err.message
    assert (err.file, err.line) == (str(rig), position(rig, "marker: {id: 0}")[0])
    assert err.column == position(rig, "marker: {id: 0}", "0}")[1]


def test_table_section_is_allowed_and_builds_the_planning_table(tmp_path):
    assert "table" in PROFILE_KEYS
    rig = write(tmp_path, SIM + "table: {z: -35}\n")
    profile = load_profile(rig)
    assert Scene.from_profile(profile).table_z == -35.0
    bare = load_profile(write(tmp_path, SIM + "table: -35\n", "bare.yaml"))
    assert Scene.from_profile(bare).table_z == -35.0
    moved = profile.with_overrides(["table.z=-35.0", "world.table.height=-35.0"])
    assert moved.data["table"] == {"z": -35.0}


@pytest.mark.parametrize(
    ("table", "words"),
    [
        ("table: {height: -35}", ["table: unknown key 'height'", "table: needs z"]),
        ("table: {z: low}", ["table.z: expected a number (mm), got 'low'"]),
        ("table: [0, 0, -35]", ["table: expected {z: MM}"]),
    ],
)
def test_bad_table_is_refused_at_its_position(tmp_path, table, words):
    rig = write(tmp_path, SIM + table + "\n")
    errors = errors_of(rig)
    assert len(errors) == len(words)
    assert all(any(e.message.startswith(w) for e in errors) for w in words)
    last = len(rig.read_text().splitlines())
    assert all(e.line == last for e in errors)


def test_place_under_the_table_is_refused_at_the_place(tmp_path):
    rig = write(
        tmp_path, SIM.replace("home: [185, 0, 30]", "home: [185, 0, -50]") + "table: {z: -35}\n"
    )
    (err,) = errors_of(rig)
    assert err.message.startswith("places.home: place 'home'") and "the table" in err.message
    assert (err.line, err.column) == position(rig, "home:", "[185")


def test_planning_table_must_be_the_simulated_table_top(tmp_path):
    rig = write(tmp_path, SIM + "table: {z: -30}\n")
    (err,) = errors_of(rig)
    assert "table top z = -30 mm differs from the simulated table's height -35 mm" in err.message
    assert (err.line, err.column) == position(rig, "table: {z", "{z")
    # The same disagreement made by an override is reported at the --set option.
    (err,) = errors_of(write(tmp_path, SIM, "ok.yaml"), ("table.z=-20",))
    assert "differs" in err.message and err.file == "--set table.z=-20"


def test_a_real_arm_profile_is_not_held_to_the_simulated_table(tmp_path):
    rig = write(
        tmp_path,
        """\
        arm: {type: dobot_v1, port: /dev/ttyUSB0}
        table: {z: -80}
        obstacles:
          - box: {center: [0, 900, 50], size: [100, 20, 100]}
        """,
    )
    scene = Scene.from_profile(load_profile(rig))
    assert scene.table_z == -80.0 and len(scene.boxes) == 1


def test_missing_mesh_file_is_refused_at_the_entry(tmp_path):
    rig = write(
        tmp_path, SIM + "obstacles:\n  - mesh: {file: fixtures/bin.stl, position: [0, 300, 0]}\n"
    )
    (err,) = errors_of(rig)
    assert err.message.startswith("obstacles[0].mesh.file: mesh file")
    assert str(tmp_path / "fixtures" / "bin.stl") in err.message and "does not exist" in err.message
    assert (err.file, err.line) == (str(rig), position(rig, "- mesh:")[0])


def test_a_mesh_that_loads_becomes_an_obstacle_and_blocks_places(tmp_path):
    (tmp_path / "block.obj").write_text(
        "v -10 -10 -10\nv 10 -10 -10\nv 10 10 -10\nv -10 10 -10\n"
        "v -10 -10 10\nv 10 -10 10\nv 10 10 10\nv -10 10 10\n"
        "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\n"
        "f 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n"
    )
    mesh = "obstacles:\n  - mesh: {file: block.obj, position: [185, 0, 30]}\n"
    rig = write(tmp_path, SIM.replace("home: [185, 0, 30]", "home: [185, 0, 80]") + mesh)
    scene = Scene.from_profile(load_profile(rig))
    assert np.allclose(scene.meshes[0].lower, [175, -10, 20])
    (err,) = errors_of(write(tmp_path, SIM + mesh, "blocked.yaml"))
    assert err.message.startswith("places.home: place 'home'") and "inside mesh" in err.message


def test_every_error_is_reported_at_once_in_file_order(tmp_path):
    text = (
        SIM.replace("port: sim}", "port: sim, colour: red}")
        .replace("at: [92, 160]", "at: [125, -140]")
        .replace("profile: t\n", "profile: t\nspeed: fast\n")
        + "obstacles:\n  - mesh: {file: nope.stl}\n"
    )
    rig = write(tmp_path, text)
    errors = errors_of(rig)
    assert len(errors) == 4, [e.message for e in errors]
    assert errors[0].message.startswith("unknown profile section 'speed'")
    assert [e.line for e in errors] == sorted(e.line for e in errors)
    assert all(e.file == str(rig) for e in errors)
    assert any("trash_a overlaps ducky" in e.message for e in errors)
    assert any("nope.stl" in e.message and "does not exist" in e.message for e in errors)
    assert any("has no parameter 'colour'" in e.message for e in errors)


def test_world_is_not_checked_again_when_tags_are_already_wrong(tmp_path):
    rig = write(
        tmp_path, SIM.replace("ducky: {id: 0, size_mm: 25}", "ducky: {id: -1, size_mm: 25}")
    )
    (err,) = errors_of(rig)
    assert err.message.startswith("tags.ducky.id: expected a marker id >= 0")


HOOKS = """
import armtree


@armtree.hookimpl
def armtree_validate_profile(profile):
    mode = (profile.data.get("description") or "").split()
    if "report" in mode:
        return [profile.error("arm.port", "this rig's port is reserved")]
    if "raise" in mode:
        raise armtree.ConfigError("raised on purpose", file="elsewhere.yaml")
    if "crash" in mode:
        return 1 / 0
    if "junk" in mode:
        return ["not an error"]
    return None
"""


@pytest.fixture()
def hooked(tmp_path):
    (tmp_path / "hooks_under_test.py").write_text(HOOKS)

    def make(description: str, extra: str = "") -> Path:
        text = SIM.replace("profile: t\n", f"profile: t\ndescription: {description}\n")
        return write(
            tmp_path, text + "plugins: [hooks_under_test.py]\n" + extra, f"{description[:6]}.yaml"
        )

    return make


def test_a_plugin_hook_reports_errors_at_positions(hooked):
    rig = hooked("report")
    (err,) = errors_of(rig)
    assert err.message == "arm.port: this rig's port is reserved"
    assert (err.line, err.column) == position(rig, "port: sim", "sim")
    (err,) = errors_of(hooked("raise"))
    assert (err.message, err.file) == ("raised on purpose", "elsewhere.yaml")
    assert load_profile(hooked("quiet")).name == "t"


def test_a_plugin_hook_that_crashes_is_named(hooked):
    (err,) = errors_of(hooked("crash"))
    assert "plugin 'hooks_under_test' failed to check the profile: ZeroDivisionError" in err.message
    (err,) = errors_of(hooked("junk"))
    assert "must return ConfigErrors, got str" in err.message


def test_a_crash_after_other_errors_is_taken_to_follow_from_them(hooked):
    (err,) = errors_of(hooked("crash", "speed: fast\n"))
    assert err.message.startswith("unknown profile section 'speed'")


SECTION_PLUGIN = """
import armtree
from armtree.config.profile_sections import ProfileSection


def check_rack(profile):
    rack = profile.data.get("rack")
    if rack is not None and rack.get("slots", 1) < 1:
        return [profile.error("rack.slots", "a rack needs at least one slot")]
    return []


@armtree.hookimpl
def armtree_profile_sections():
    return {"rack": ProfileSection({"type": "object", "description": "a tool rack"}, check_rack)}
"""


def test_a_section_a_plugin_registers_is_accepted_typed_and_checked_at_its_position(tmp_path):
    (tmp_path / "rack_plugin.py").write_text(SECTION_PLUGIN)
    without = write(tmp_path, SIM + "rack: {slots: 2}\n", "without.yaml")
    (err,) = errors_of(without)
    assert err.message.startswith("unknown profile section 'rack'")
    rig = write(tmp_path, SIM + "plugins: [rack_plugin.py]\nrack: {slots: 0}\n")
    (err,) = errors_of(rig)
    assert err.message == "rack.slots: a rack needs at least one slot"
    assert (err.file, err.line, err.column) == (str(rig), *position(rig, "slots: 0", "0"))
    assert load_profile(rig, ("rack.slots=3",)).data["rack"] == {"slots": 3}
    (err,) = errors_of(write(tmp_path, SIM + "plugins: [rack_plugin.py]\nrack: 3\n"))
    assert err.message == "rack: expected a mapping" and err.line == SIM.count("\n") + 2


def test_world_is_the_sim_plugins_section():
    from armtree.hooks.plugin_manager import PluginManager

    manager = PluginManager(blocked=["sim"], autoload=False)
    manager.load_entry_points()
    assert "world" not in PROFILE_KEYS
    with pytest.raises(ConfigError, match="unknown profile section 'world'"):
        load_profile("sim_dobot", manager=manager)
    assert load_profile("sim_dobot").section("world") is not None
