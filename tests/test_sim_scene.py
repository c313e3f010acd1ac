"""The world: section is validated at load time, naming the bad entry."""

from __future__ import annotations

from importlib import resources

import pytest
import yaml

from armtree.errors import ConfigError
from armtree.plugins.sim.scene import parse_scene

WORLD = {
    "table": {"x": [-200, 400], "y": [-300, 300]},
    "objects": {
        "ducky": {"kind": "ducky", "at": [200, -100]},
        "trash_a": {"kind": "trash", "at": [150, 100]},
        "trash_b": {"kind": "trash", "at": [250, 100]},
        "bin": {"kind": "bin", "at": [0, 200]},
    },
    "duckybots": {"bot": {"start": [300, -200, 90], "route": [{"park": [300, 0, 90]}]}},
}


@pytest.fixture
def with_world(sim_profile):
    """A factory: the profile with ``a__b=value`` changes made in its world."""

    def make(**changes):
        profile = sim_profile(WORLD)
        for path, value in changes.items():
            node = profile["world"]
            keys = path.split("__")
            for key in keys[:-1]:
                node = node[key]
            node[keys[-1]] = value
        return profile

    return make


def test_valid_world_gets_markers_from_the_tags(with_world):
    scene = parse_scene(with_world())
    markers = {o.name: o.marker.id if o.marker else None for o in scene.objects}
    assert markers == {"ducky": 0, "trash_a": 2, "trash_b": 3, "bin": None}
    assert scene.duckybots[0].body.marker.id == 1
    assert scene.duckybots[0].route.legs[0].kind == "park"


@pytest.mark.parametrize(
    ("changes", "words"),
    [
        ({"objects__ducky__shape": "sphere"}, ["world.objects.ducky.shape", "sphere"]),
        ({"objects__ducky__kind": "duck"}, ["world.objects.ducky.kind", "did you mean 'ducky'"]),
        ({"objects__ducky__colour": [1, 2, 3]}, ["world.objects.ducky.colour", "did you mean"]),
        ({"objects__ducky__at": [500, 0]}, ["world.objects.ducky", "off the table"]),
        ({"objects__trash_a__at": [205, -95]}, ["trash_a overlaps ducky"]),
        ({"objects__trash_a__marker": {"id": 0}}, ["trash_a.marker.id", "'ducky' tag"]),
        ({"objects__trash_a__marker": {"id": 9}}, ["trash_a.marker.id", "not among the 'trash'"]),
        ({"objects__ducky__marker": {"size_mm": 20}}, ["ducky.marker.size_mm", "differs"]),
        ({"objects__ducky__size": [10, 10, 10]}, ["does not fit"]),
        ({"objects__ducky__size": [-1, 10, 10]}, ["world.objects.ducky.size", "positive"]),
        ({"duckybots__bot__route": [[900, 0]]}, ["world.duckybots.bot.route.0", "off the table"]),
        ({"duckybots__bot__start": [205, -100, 0]}, ["bot overlaps ducky"]),
        ({"objects__bin__wall_mm": 60}, ["world.objects.bin.wall_mm"]),
        ({"seed": "x"}, ["world.seed"]),
    ],
)
def test_bad_world_is_a_config_error_naming_the_entry(changes, words, with_world):
    with pytest.raises(ConfigError) as info:
        parse_scene(with_world(**changes))
    for word in words:
        assert word in str(info.value)


def test_marker_id_outside_the_dictionary(with_world):
    profile = with_world(objects__trash_a__marker={"id": 2})
    profile["tracker"]["dictionary"] = "4x4_50"
    profile["tags"]["trash"]["ids"] = [2, 77]
    profile["world"]["objects"]["trash_b"]["marker"] = {"id": 77}
    with pytest.raises(ConfigError, match="4x4_50 has ids 0 to 49, not 77"):
        parse_scene(profile)


def test_object_inside_a_bin_is_allowed_but_not_through_its_wall(with_world):
    inside = with_world(objects__trash_a__at=[0, 200, 3])
    scene = parse_scene(inside)
    assert any(o.name == "trash_a" for o in scene.objects)
    with pytest.raises(ConfigError, match="bin overlaps trash_a"):
        parse_scene(with_world(objects__trash_a__at=[40, 200, 3]))


def test_profile_obstacles_join_the_world(with_world):
    profile = with_world()
    profile["obstacles"] = [{"box": {"center": [100, -200, 40], "size": [40, 40, 80]}}]
    scene = parse_scene(profile)
    obstacle = next(o for o in scene.objects if o.name == "obstacles[0]")
    assert obstacle.kind == "obstacle"
    assert obstacle.position.tolist() == [100, -200, 0]


def test_error_carries_file_and_line_from_a_loaded_profile(tmp_path):
    from armtree.loader.profile import load_profile

    text = resources.files("armtree.hardware").joinpath("sim_dobot.yaml").read_text()
    text = text.replace("trash_a: {kind: trash,", "trash_a: {kind: trash, shape: sphere,")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    # The sim plugin's armtree_validate_profile parses the world while the profile loads.
    with pytest.raises(ConfigError) as info:
        load_profile(str(path))
    err = info.value
    assert err.file is not None and err.file.endswith("bad.yaml")
    line = next(i for i, s in enumerate(text.splitlines(), 1) if "shape: sphere" in s)
    assert err.line == line
    assert "world.objects.trash_a.shape" in str(err)


@pytest.mark.parametrize("name", ["sim_dobot.yaml", "sim_vicra.yaml"])
def test_shipped_profiles_have_valid_worlds(name):
    data = yaml.safe_load(resources.files("armtree.hardware").joinpath(name).read_text())
    scene = parse_scene(data)
    kinds = {o.kind for o in scene.objects}
    assert {"ducky", "trash", "bin", "spot", "obstacle"} <= kinds
    assert len(scene.duckybots) == 1
    assert any(leg.kind == "park" for leg in scene.duckybots[0].route.legs)
