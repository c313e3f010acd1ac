"""``tags:`` ids against their marker families, and ``armtree markers``' ids: bad input is
exit 2 at FILE:LINE:COL (or naming the option) with valid alternatives, through the CLI."""

from __future__ import annotations

import textwrap

import pytest

from armtree.api.rig import TagSpec
from armtree.cli import commandline as cli

TREE = "rig: rig.yaml\nroot: {success: {}}\n"
GOOD_TAGS = """\
tags:
  ducky: {id: 0, size_mm: 25, family_ids: {hamming: 69937}}
  trash: {ids: [2, 3], size_mm: 25, family_ids: {hamming: [70026, 70124]}}
"""


def check(tmp_path, capsys, tracker: str, tags: str, *extra: str) -> tuple[int, str]:
    (tmp_path / "rig.yaml").write_text(
        "profile: rig\narm: {type: dobot_v1, port: sim}\n"
        f"tracker: {tracker}\n" + textwrap.dedent(tags)
    )
    (tmp_path / "t.yaml").write_text(TREE)
    code = cli.main(["check", str(tmp_path / "t.yaml"), *extra])
    return code, capsys.readouterr().err


@pytest.mark.parametrize(
    "tracker",
    ["{type: hamming}", "{type: apriltag}", "{type: aruco, dictionary: apriltag_36h11}"],
)
def test_per_family_ids_load_for_every_tracker(tmp_path, capsys, tracker):
    code, err = check(tmp_path, capsys, tracker, GOOD_TAGS)
    assert code == 0, err


@pytest.mark.parametrize(
    ("tracker", "tags", "at", "words"),
    [
        # the tracker reads hamming, and the role has no hamming id: its plain id is checked
        (
            "{type: hamming}",
            "tags:\n  ducky: {id: 0, size_mm: 25}\n",
            "0,",
            ["tags.ducky.id: hamming id 0 cannot be read", "all black", "275, 277, 279",
             "family_ids: {hamming: N}"],
        ),
        # a hamming id whose orientation is not unique, written for the family
        (
            "{type: aruco}",
            "tags:\n  ducky: {id: 0, size_mm: 25, family_ids: {hamming: 7}}\n",
            "7}",
            ["tags.ducky.family_ids.hamming: hamming id 7 cannot be read", "turned 180 degrees",
             "valid ids near it"],
        ),
        # the tracker's corrections decide which hamming ids are valid
        (
            "{type: hamming, max_corrected_bits: 3}",
            "tags:\n  ducky: {id: 275, size_mm: 25}\n",
            "275",
            ["hamming id 275 cannot be read", "the tracker allows 3"],
        ),
        # an id past the family's range
        (
            "{type: apriltag}",
            "tags:\n  ducky: {id: 600, size_mm: 25}\n",
            "600",
            ["apriltag_36h11 has ids 0 to 586, not 600", "586, 585, 584"],
        ),
        (
            "{type: aruco}",
            "tags:\n  ducky: {id: 0, size_mm: 25, family_ids: {4x4_50: 50}}\n",
            "50}",
            ["4x4_50 has ids 0 to 49, not 50"],
        ),
        # an unknown family
        (
            "{type: aruco}",
            "tags:\n  ducky: {id: 0, size_mm: 25, family_ids: {haming: 69937}}\n",
            "69937",
            ["unknown marker family 'haming'", "did you mean 'hamming'"],
        ),
        # a family written another way than its name
        (
            "{type: aruco}",
            "tags:\n  ducky: {id: 0, size_mm: 25, family_ids: {DICT_4X4_50: 3}}\n",
            "3}",
            ["write the family as '4x4_50'"],
        ),
        # one id, two roles, in one family (the plain ids differ)
        (
            "{type: hamming}",
            """\
            tags:
              ducky: {id: 0, size_mm: 25, family_ids: {hamming: 69937}}
              duckybot: {id: 1, size_mm: 25, family_ids: {hamming: 69937}}
            """,
            "69937",
            ["hamming id 69937 is both 'ducky' (tags.ducky.family_ids.hamming) and 'duckybot'"],
        ),
        # ... or one role's plain id is the other's id in that family
        (
            "{type: aruco}",
            """\
            tags:
              ducky: {id: 3, size_mm: 25}
              duckybot: {id: 1, size_mm: 25, family_ids: {4x4_50: 3}}
            """,
            "3}",
            ["4x4_50 id 3 is both 'ducky' (tags.ducky.id) and 'duckybot'"],
        ),
        # family_ids shaped as the role's ids
        (
            "{type: aruco}",
            "tags:\n  trash: {ids: [2, 3], size_mm: 25, family_ids: {hamming: 69937}}\n",
            "69937",
            ["expected a list of 2 marker ids, one for each of tags.trash.ids"],
        ),
        (
            "{type: aruco}",
            "tags:\n  ducky: {id: 0, size_mm: 25, family: hamming}\n",
            "family:",
            ["unknown key 'family'", "did you mean 'family_ids'"],
        ),
        # sizes
        ("{type: hamming}", "tags:\n  ducky: {id: 69937, size_mm: 0}\n", "0}", ["> 0 (mm)"]),
        ("{type: hamming}", "tags:\n  ducky: {id: 69937, size_mm: -5}\n", "-5", ["> 0 (mm)"]),
        # the tracker's family itself
        ("{type: apriltag, family: 37h11}", "tags: {}\n", "37h11", ["36h11"]),
        (
            "{type: aruco, dictionary: apriltag_36h12}",
            "tags: {}\n",
            "apriltag_36h12",
            ["did you mean 'apriltag_36h11'"],
        ),
    ],
)  # fmt: skip
def test_bad_tags_are_exit_2_at_their_position(tmp_path, capsys, tracker, tags, at, words):
    code, err = check(tmp_path, capsys, tracker, tags)
    assert code == 2, err
    # the error points at the last line that holds ``at``, where ``at`` starts
    lines = (tmp_path / "rig.yaml").read_text().splitlines()
    line = max(n for n, text in enumerate(lines, start=1) if at in text)
    column = lines[line - 1].index(at) + 1
    first = err.splitlines()[0]
    assert first.startswith(f"{tmp_path / 'rig.yaml'}:{line}:{column}: "), first
    for word in words:
        assert word in err
    assert "Traceback" not in err


def test_swapping_the_tracker_with_set_checks_the_new_family(tmp_path, capsys):
    tags = "tags:\n  ducky: {id: 0, size_mm: 25}\n"
    assert check(tmp_path, capsys, "{type: aruco}", tags)[0] == 0
    code, err = check(tmp_path, capsys, "{type: aruco}", tags, "--set", "tracker.type=hamming")
    assert code == 2 and "rig.yaml:5:15: tags.ducky.id: hamming id 0 cannot be read" in err


def test_the_rig_and_the_trackers_read_each_roles_ids_in_their_family(tmp_path):
    import armtree

    (tmp_path / "rig.yaml").write_text(
        "profile: rig\narm: {type: dobot_v1, port: sim}\ntracker: {type: hamming}\n" + GOOD_TAGS
    )
    profile = armtree.load_profile(str(tmp_path / "rig.yaml"))
    trash = profile.tags()["trash"]
    assert trash == TagSpec("trash", (2, 3), 25.0, {"hamming": (70026, 70124)})
    assert trash.in_family("hamming").ids == (70026, 70124)
    assert trash.in_family("apriltag_36h11").ids == trash.in_family(None).ids == (2, 3)
    from armtree.plugins.trackers.common import tag_table

    assert sorted(tag_table(profile, "hamming")) == [69937, 70026, 70124]
    assert sorted(tag_table(profile, "4x4_50")) == [0, 2, 3]


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--family", "hamming", "--id", "0"], ["--id 0: hamming id 0 cannot be read",
                                                "valid ids near it: 275, 277, 279"]),
        (["--family", "hamming", "--id", "1"], ["turned 180 degrees"]),
        (["--family", "hamming", "--id", str(2**28)], ["hamming has ids 0 to 2**28 - 1"]),
        (["--family", "apriltag", "--id", "587"], ["apriltag_36h11 has ids 0 to 586, not 587"]),
        (["--family", "aruco", "--dictionary", "apriltag_36h11", "--id", "600"], ["0 to 586"]),
        (["--family", "hamming", "--sheet", "69937,7"], ["--id 7: hamming id 7"]),
        (["--family", "apriltg", "--id", "1"], ["unknown marker family 'apriltg'", "apriltag"]),
        (["--family", "apriltag", "--dictionary", "36h12", "--id", "1"], ["36h11"]),
        (["--family", "hamming", "--dictionary", "36h11", "--id", "69937"], ["--dictionary"]),
        (["--family", "hamming", "--id", "69937", "--size-mm", "0"], ["positive"]),
        (["--family", "hamming", "--id", "69937", "--size-mm", "-3"], ["positive"]),
    ],
)  # fmt: skip
def test_markers_refuses_what_its_family_cannot_carry(tmp_path, capsys, argv, words):
    code = cli.main(["markers", *argv, "-o", str(tmp_path / "m.png")])
    err = capsys.readouterr().err
    assert code == 2, err
    for word in words:
        assert word in err
    assert not (tmp_path / "m.png").exists() and "Traceback" not in err


@pytest.mark.parametrize(
    ("family", "marker_id", "tracker"),
    [("hamming", 69937, "hamming"), ("apriltag", 586, "apriltag"), ("aruco", 49, "aruco")],
)
def test_markers_writes_what_detect_reads(tmp_path, capsys, family, marker_id, tracker):
    out = tmp_path / "m.png"
    assert cli.main(["markers", "--family", family, "--id", str(marker_id), "-o", str(out)]) == 0
    capsys.readouterr()
    assert cli.main(["detect", "--tracker", tracker, str(out)]) == 0
    assert f"id {marker_id}" in capsys.readouterr().out
