"""Swapping hardware with one key: ``--set arm.type=NAME`` on a profile written for another arm."""

import pytest

import armtree


def test_swapped_arm_type_drops_the_keys_only_the_previous_type_takes():
    vicra = armtree.load_profile("sim_dobot", overrides=["arm.type=vicra"]).data["arm"]
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
