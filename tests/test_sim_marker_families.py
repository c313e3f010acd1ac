"""The sim draws tagged bodies in the family its profile's tracker reads, with the ids the
profile gives that family, and refuses a marker that family's tracker could not read."""

from __future__ import annotations

import copy

import pytest

from armtree.errors import ConfigError
from armtree.plugins.sim.scene import parse_scene

WORLD = {
    "table": {"x": [-200, 400], "y": [-300, 300]},
    "objects": {
        "ducky": {"kind": "ducky", "at": [200, -100]},
        "trash_a": {"kind": "trash", "at": [150, 100]},
        "sheet": {"kind": "spot", "at": [50, -150], "marker": {"id": 9}},
    },
    "duckybots": {"bot": {"start": [300, -200, 90], "route": [{"park": [300, 0, 90]}]}},
    "randomize": {"objects": {"trash": {"count": [2, 2], "ring": {"r": [150, 250]}}}},
}
TAGS = {
    "ducky": {"id": 0, "size_mm": 25, "family_ids": {"hamming": 69937}},
    "duckybot": {"id": 1, "size_mm": 25, "family_ids": {"hamming": 69975}},
    "trash": {"ids": [2, 3], "size_mm": 25, "family_ids": {"hamming": [70026, 70124]}},
    "target": {"id": 9, "size_mm": 25, "family_ids": {"hamming": 70517}},
}


def profile(tracker: dict, tags: dict = TAGS, **objects) -> dict:
    world = copy.deepcopy(WORLD)
    world["objects"].update(objects)
    return {"tracker": tracker, "tags": copy.deepcopy(tags), "world": world}


def drawn(scene) -> dict[str, tuple[str, str, int, str | None]]:
    bodies = [*scene.objects, *(b.body for b in scene.duckybots)]
    return {
        b.name: (b.marker.family, b.marker.dictionary, b.marker.id, b.marker.role)
        for b in bodies
        if b.marker is not None
    }


@pytest.mark.parametrize(
    ("tracker", "family", "dictionary", "ids"),
    [
        ({"type": "aruco"}, "aruco", "4x4_50", (0, 2, 9, 1)),
        ({"type": "apriltag"}, "aruco", "apriltag_36h11", (0, 2, 9, 1)),
        ({"type": "aruco", "dictionary": "apriltag_36h11"}, "aruco", "apriltag_36h11", (0, 2, 9, 1)),
        ({"type": "hamming"}, "hamming", "4x4_50", (69937, 70026, 70517, 69975)),
    ],
)  # fmt: skip
def test_bodies_carry_the_trackers_family_and_ids(tracker, family, dictionary, ids):
    markers = drawn(parse_scene(profile(tracker)))
    ducky, trash, target, bot = ids
    assert markers == {
        "ducky": (family, dictionary, ducky, "ducky"),
        "trash_a": (family, dictionary, trash, "trash"),
        # a world entry writes the plain id; the sheet is the target tag in any family
        "sheet": (family, dictionary, target, "target"),
        "bot": (family, dictionary, bot, "duckybot"),
    }


def test_spare_bodies_take_the_next_ids_of_the_family():
    scene = parse_scene(profile({"type": "hamming"}))
    trash = [o for o in scene.objects if o.kind == "trash"] + scene.randomize.spares["trash"]
    assert [(o.marker.family, o.marker.id) for o in trash] == [
        ("hamming", 70026),
        ("hamming", 70124),
    ]


def test_an_explicit_family_draws_that_family_whatever_the_tracker():
    markers = drawn(
        parse_scene(
            profile(
                {"type": "aruco"},
                ducky={"kind": "ducky", "at": [200, -100], "marker": {"family": "hamming"}},
            )
        )
    )
    assert markers["ducky"] == ("hamming", "4x4_50", 69937, "ducky")
    assert markers["trash_a"] == ("aruco", "4x4_50", 2, "trash")


@pytest.mark.parametrize(
    ("tracker", "tags", "ducky_marker", "words"),
    [
        # the tracker reads hamming, the profile gives no hamming ids: id 0 is all black
        (
            {"type": "hamming"},
            {"ducky": {"id": 0, "size_mm": 25}},
            None,
            ["world.objects.ducky", "hamming id 0 cannot be read", "275, 277, 279"],
        ),
        # a marker written for a family that cannot carry it
        (
            {"type": "aruco"},
            {"ducky": {"id": 0, "size_mm": 25, "family_ids": {"hamming": 7}}},
            {"family": "hamming"},
            ["hamming id 7 cannot be read", "turned 180 degrees"],
        ),
        (
            {"type": "apriltag"},
            {"ducky": {"id": 600, "size_mm": 25}},
            None,
            ["apriltag_36h11 has ids 0 to 586, not 600"],
        ),
        (
            {"type": "aruco"},
            TAGS,
            {"family": "aprltag"},
            ["world.objects.ducky.marker.family", "unknown marker family 'aprltag'"],
        ),
    ],
)
def test_the_sim_refuses_a_marker_its_family_cannot_carry(tracker, tags, ducky_marker, words):
    ducky = {"kind": "ducky", "at": [200, -100]}
    if ducky_marker is not None:
        ducky["marker"] = ducky_marker
    bad = profile(tracker, tags, ducky=ducky)
    bad["world"]["objects"] = {"ducky": ducky}
    bad["world"].pop("randomize")
    bad["world"]["duckybots"] = {}
    with pytest.raises(ConfigError) as err:
        parse_scene(bad)
    for word in words:
        assert word in str(err.value)


def test_a_printed_sheet_of_an_unreadable_id_is_refused():
    bad = profile({"type": "aruco"})
    bad["world"]["objects"]["sheet"]["marker"] = {"family": "hamming", "id": 12}
    with pytest.raises(ConfigError, match="world.objects.sheet.marker.id: hamming id 12 cannot"):
        parse_scene(bad)
