"""Swapping hardware with one key: ``--set arm.type=NAME`` on a profile written for another arm."""

from pathlib import Path

import pytest

import armtree
from armtree.plugins.sim.rig_world import sim_world


def test_swapped_arm_type_drops_the_keys_only_the_previous_type_takes(tmp_path):
    path = tmp_path / "dobot.yaml"
    path.write_text(
        "profile: dobot\narm: {type: dobot_v1, port: sim, firmware: original, tool_offset_mm: 55}\n"
    )
    vicra = armtree.load_profile(path, overrides=["arm.type=vicra"]).data["arm"]
    assert vicra["type"] == "vicra" and vicra["port"] == "sim"
    assert "firmware" not in vicra and "tool_offset_mm" not in vicra
    magician = armtree.load_profile("sim_dobot", overrides=["arm.type=dobot_magician"]).data["arm"]
    assert "firmware" not in magician
    assert magician["tool_offset_mm"] == 55, "a key the new type takes is kept"


def test_a_key_given_with_the_swap_is_still_checked():
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile("sim_dobot", overrides=["arm.type=vicra", "arm.firmware=open-dobot"])
    assert "vicra has no parameter 'firmware'" in str(info.value)
    assert info.value.file == "--set arm.firmware=open-dobot"


def test_without_a_swap_a_foreign_key_is_an_error(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text("profile: p\narm: {type: vicra, port: sim, firmware: original}\n")
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile(path)
    assert (info.value.line, info.value.column) == (2, 31)


# -- a swapped arm must fit the rest of the profile (plugins/arms/fit.py) ------------------


def test_places_out_of_the_new_arms_reach_fail_at_their_line_and_column():
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile("sim_dobot", overrides=["arm.type=vicra"])
    (error,) = info.value.errors
    lines = Path(error.file).read_text().splitlines()
    line = next(n for n, text in enumerate(lines, 1) if text.startswith("  ducky_pickup:"))
    column = lines[line - 1].index("[") + 1
    assert error.file.endswith("sim_dobot.yaml") and (error.line, error.column) == (line, column)
    assert error.message.startswith("places.ducky_pickup: [119.0, -142.0, -10.0] mm is out of")
    assert "reach of vicra" in error.message and "written for dobot_v1" in error.message


def test_every_misfit_is_named():
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile("sim_vicra", overrides=["arm.type=dobot_v1"])
    named = [e.message.split(":")[0] for e in info.value.errors]
    assert named == ["places.home", "places.ducky_pickup", "places.garbage_bin"]


def test_a_swap_that_fits_loads_and_keeps_the_keys_both_arms_take():
    profile = armtree.load_profile("sim_dobot", overrides=["arm.type=dobot_magician"])
    assert profile.swaps["arm"].previous == "dobot_v1"
    assert set(profile.swaps["arm"].dropped) == {"firmware"}
    assert profile.data["arm"]["tool_offset_mm"] == 55


def test_a_tool_the_new_arm_does_not_grip_with_is_named_where_it_was_written(tmp_path):
    path = tmp_path / "gripper.yaml"
    path.write_text(
        "profile: gripper\n"
        "arm: {type: vicra, port: sim, tool: gripper}\n"
        "places: {over: [250, 0, 20]}\n"
    )
    assert armtree.load_profile(path).swaps == {}
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile(path, overrides=["arm.type=dobot_magician"])
    (error,) = info.value.errors
    assert (error.line, error.column) == (2, 31)
    assert error.message.startswith("arm.tool: gripper: dobot_magician grips with suction")


def test_an_eye_in_hand_camera_written_for_another_tool_frame_is_named(tmp_path):
    # sim_dh's arm points its tool's z axis down; a Magician's tool frame keeps z up
    arm = armtree.load_profile("sim_dh").data["arm"]
    path = tmp_path / "hand.yaml"
    path.write_text(
        f"profile: hand\narm: {arm!r}\n".replace("'", '"').replace("None", "null")
        + "camera: {type: sim, mount: eye_in_hand, position: [0, 40, 60]}\n"
    )
    armtree.load_profile(path)
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile(path, overrides=["arm.type=dobot_magician"])
    (error,) = info.value.errors
    assert error.line == 3 and error.message.startswith("camera.mount: eye_in_hand")
    assert "180 degrees" in error.message


def test_the_command_line_exits_2_naming_the_key(capsys):
    from armtree.cli.commandline import main

    assert (
        main(["check", "load_ducky.yaml", "--rig", "sim_vicra", "--set", "arm.type=dobot_v1"]) == 2
    )
    err = capsys.readouterr().err
    lines = (
        (Path(armtree.__file__).parent.parent / "hardware" / "sim_vicra.yaml")
        .read_text()
        .splitlines()
    )
    line = next(n for n, text in enumerate(lines, 1) if text.startswith("  ducky_pickup:"))
    assert f"sim_vicra.yaml:{line}:17: places.ducky_pickup:" in err and "Traceback" not in err


@pytest.mark.slow
def test_the_readme_swap_loads_the_ducky_with_a_magician_in_sim_dobots_world():
    from armtree.loader.tree_loader import load_tree
    from armtree.runtime.runner import Run

    tree = load_tree("load_ducky.yaml", rig="sim_dobot", overrides=["arm.type=dobot_magician"])
    run = Run(tree, None, seed=0, record=False, max_ticks=4000, quiet=True)
    result = run.execute()
    score = sim_world(run).score()
    assert type(run.rig.arm).__name__ == "MagicianDriver"
    assert result.status == "SUCCESS", result.message
    assert score["ducky_on_duckybot"] and score["collision_count"] == 0, score["collisions"]
