"""The ``workcell:`` profile section: parsed for the skills, every error at its position."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
from test_profile_load import manager

import armtree
from armtree.api.skill.survey import grid_points, survey_points
from armtree.config.workcell import Survey, parse_workcell, workcell_of


def load(tmp_path, body: str):
    path = tmp_path / "rig.yaml"
    path.write_text(
        "arm: {type: vicra}\nplaces: {bin: [0, 100, 20]}\ntags: {trash: {id: 2, size_mm: 25}}\n"
        + textwrap.dedent(body)
    )
    return armtree.load_profile(path, manager=manager())


def errors(tmp_path, body: str) -> list[str]:
    with pytest.raises(armtree.ConfigError) as info:
        load(tmp_path, body)
    return [f"{e.line}:{e.column}: {e.message}" for e in info.value.errors]


@pytest.mark.parametrize(
    "name", ["sim_dobot", "sim_vicra", "sim_magician", "sim_dh", "sim_so101", "sim_koch"]
)
def test_the_sim_profiles_carry_what_their_skills_need(name):
    cell = workcell_of(armtree.load_profile(name))
    assert cell.table_z_mm is not None and cell.clearance_z_mm is not None
    assert cell.survey is not None and cell.survey.shape == "ring"
    assert cell.sort == {"trash": "garbage_bin"}
    # the bin the trash goes to is described, so drops spread across it
    assert set(cell.bins) == {"garbage_bin"}
    assert all(s > 0 for s in cell.bins["garbage_bin"].size_mm)


def test_a_full_section_is_parsed_with_units_as_written(tmp_path):
    profile = load(
        tmp_path,
        """\
        workcell:
          table_z_mm: -35
          clearance_z_mm: 20
          survey: {rectangle: {x_mm: [100, 200], y_mm: [-50, 50], step_mm: 50}}
          grasp_offset_mm: -10
          sort: {trash: bin}
        """,
    )
    cell = workcell_of(profile)
    assert cell.table_z_mm == -35.0 and cell.grasp_offset_mm == -10.0
    assert cell.look_height_mm == 120.0  # the default
    assert cell.survey == Survey("rectangle", x_mm=(100.0, 200.0), y_mm=(-50.0, 50.0), step_mm=50.0)
    assert cell.sort == {"trash": "bin"}


def test_the_table_section_stands_in_for_a_missing_table_height():
    assert parse_workcell({}, table_z=12.5).table_z_mm == 12.5
    assert parse_workcell({"table_z_mm": 3}, table_z=12.5).table_z_mm == 3.0


def test_every_mistake_is_reported_at_its_line_and_column(tmp_path):
    found = errors(
        tmp_path,
        """\
        workcell:
          table_z_mm: low
          clearnce_z_mm: 20
          look_height_mm: -5
          survey: {ring: {radius_mm: 0, range_deg: [100, -100]}}
          sort: {ducky: bin, trash: nowhere}
        """,
    )
    assert found == [
        "5:15: workcell.table_z_mm: expected a number (mm) within +/-5000, got 'low'",
        "6:3: workcell: unknown key 'clearnce_z_mm'; did you mean 'clearance_z_mm'?",
        "7:19: workcell.look_height_mm: expected a number > 0 mm, got -5",
        "8:30: workcell.survey.ring.radius_mm: expected a radius > 0 and <= 5000 (mm), "
        "or a list of 1 to 8 such radii, got 0",
        "8:44: workcell.survey.ring.range_deg: expected [lo, hi] base angles within +/-360 (deg), "
        "lo <= hi, got [100, -100]",
        "9:10: workcell.sort: 'ducky' is not a tag role (tags: trash)",
        "9:29: workcell.sort.trash: 'nowhere' is not a place (places: bin)",
    ]


def test_a_survey_is_exactly_one_shape(tmp_path):
    found = errors(tmp_path, "workcell: {survey: {ring: {radius_mm: 100}, viewpoints: [[1, 2]]}}\n")
    assert len(found) == 1 and "expected one of ring" in found[0] and found[0].startswith("4:")
    found = errors(tmp_path, "workcell: {survey: {viewpoints: [[1, 2], [1, 2, 3, 4]]}}\n")
    assert found == [
        "4:42: workcell.survey.viewpoints[1]: expected [x, y] or [x, y, z] in mm, got [1, 2, 3, 4]"
    ]


@pytest.mark.parametrize(
    ("option", "message"),
    [
        ("survey.ring.step_deg=1e-9", "expected a step of 0.1 to 360 (deg)"),
        ("survey.ring.range_deg=[-1e300, 1e300]", "base angles within +/-360 (deg)"),
        ("survey.rectangle={x_mm: [0, 4000], y_mm: [0, 4000], step_mm: 1}", "a grid of"),
        ("clearance_z_mm=1e300", "expected a number (mm) within +/-5000"),
        ("survey.ring.radius_mm=[]", "or a list of 1 to 8 such radii"),
        ("survey.ring.radius_mm=[200, -5]", "or a list of 1 to 8 such radii"),
        ("survey.ring.radius_mm=[1, 2, 3, 4, 5, 6, 7, 8, 9]", "or a list of 1 to 8 such radii"),
    ],
)
def test_values_that_would_sweep_without_bound_fail_naming_the_option(option, message):
    survey = ["workcell.survey=null"] if "rectangle" in option else []
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_profile("sim_dobot", [*survey, f"workcell.{option}"])
    assert info.value.file == f"--set workcell.{option}"
    assert message in info.value.message


def test_a_ring_survey_sweeps_from_the_tool_s_heading_on_the_table():
    ring = Survey("ring", radius_mm=100.0, range_deg=(-20.0, 20.0), step_deg=10.0)
    points = survey_points(ring, -35.0, np.array([50.0, 0.0, 0.0]), sweeps=2)
    headings = [round(float(np.degrees(np.arctan2(p[1], p[0]))), 6) for p in points]
    assert headings == [0, 10, 20, 15, 5, -5, -15, -20]
    assert all(np.isclose(np.hypot(p[0], p[1]), 100.0) and p[2] == -35.0 for p in points)


def test_a_ring_of_two_radii_looks_from_each_at_every_angle_out_and_back_in():
    ring = Survey(
        "ring", radius_mm=90.0, range_deg=(0.0, 20.0), step_deg=10.0, radii_mm=(90.0, 110.0)
    )
    points = survey_points(ring, -35.0, np.array([50.0, 0.0, 0.0]), sweeps=1)
    looks = [
        (round(float(np.degrees(np.arctan2(p[1], p[0])))), round(float(np.hypot(p[0], p[1]))))
        for p in points
    ]
    assert looks == [(0, 90), (0, 110), (10, 110), (10, 90), (20, 90), (20, 110)]


def test_a_profile_s_radius_list_becomes_the_ring_s_radii():
    cell = workcell_of(
        armtree.load_profile("sim_dobot", ["workcell.survey.ring.radius_mm=[170, 195]"])
    )
    assert cell.survey.radii_mm == (170.0, 195.0) and cell.survey.radius_mm == 170.0


def test_a_rectangle_is_covered_row_by_row_and_retraced():
    rect = Survey("rectangle", x_mm=(0.0, 100.0), y_mm=(0.0, 40.0), step_mm=50.0)
    assert grid_points(rect) == [(0, 0), (50, 0), (100, 0), (100, 40), (50, 40), (0, 40)]
    points = survey_points(rect, 5.0, np.array([90.0, 45.0, 0.0]), sweeps=2)
    xy = [tuple(p[:2]) for p in points]
    assert xy[:6] == [(100, 40), (50, 40), (0, 40), (0, 0), (50, 0), (100, 0)]  # nearest first
    assert xy[6:] == xy[:5][::-1] and all(p[2] == 5.0 for p in points)


def test_viewpoints_keep_their_own_height_and_a_single_one_is_looked_at_every_leg():
    views = Survey("viewpoints", points=((10.0, 20.0), (30.0, 40.0, 7.0)))
    points = survey_points(views, 1.0, np.zeros(3), sweeps=1)
    assert [p.tolist() for p in points] == [[10, 20, 1], [30, 40, 7]]
    one = Survey("viewpoints", points=((10.0, 20.0),))
    assert len(survey_points(one, 1.0, np.zeros(3), sweeps=3)) == 3


def test_marker_heights_name_tag_roles_and_are_not_negative(tmp_path):
    found = errors(tmp_path, "workcell: {marker_heights_mm: {trash: -1, ducky: 30}}\n")
    assert len(found) == 2
    assert "marker_heights_mm.trash: expected a height >= 0 (mm)" in found[0] + found[1]
    assert "'ducky' is not a tag role" in found[0] + found[1]
    cell = workcell_of(
        load(tmp_path, "workcell: {table_z_mm: 5, marker_heights_mm: {trash: 20}}\n")
    )
    assert cell.marker_heights_mm == {"trash": 20.0}


def test_a_bin_names_a_place_and_gives_its_inside_and_rim(tmp_path):
    found = errors(
        tmp_path,
        """\
        workcell:
          bins:
            bni: {size_mm: [74, 74], rim_z_mm: -15}
            bin: {size_mm: [74, 0], rim: 3}
        """,
    )
    text = "\n".join(found)
    assert "6:5: workcell.bins: 'bni' is not a place (places: bin)" in text
    assert "7:29: workcell.bins.bin: unknown key 'rim'" in text
    assert "7:10: workcell.bins.bin: needs rim_z_mm" in text
    assert "workcell.bins.bin.size_mm: expected [x, y], each > 0" in text
    cell = workcell_of(
        load(tmp_path, "workcell: {bins: {bin: {size_mm: [74, 60], rim_z_mm: -15}}}\n")
    )
    assert cell.bins["bin"].size_mm == (74.0, 60.0) and cell.bins["bin"].rim_z_mm == -15.0


def test_a_marker_is_moved_along_the_camera_ray_onto_its_height():
    from armtree.api.skill.eye import onto_plane

    camera = np.eye(4)
    camera[:3, 3] = [300.0, 0.0, 650.0]
    measured = np.array([250.0, 250.0, 18.0])  # the range along the ray a little long
    fixed = onto_plane(camera, measured, 25.0)
    assert np.isclose(fixed[2], 25.0, atol=1e-9)
    ray = measured - camera[:3, 3]
    assert np.allclose(np.cross(fixed - camera[:3, 3], ray), 0.0, atol=1e-6)  # same ray


def test_a_sweep_on_a_profile_without_a_survey_is_refused_at_load(tmp_path):
    profile = tmp_path / "rig.yaml"
    profile.write_text(
        "arm: {type: vicra}\ncamera: {type: sim}\ntracker: {type: aruco}\n"
        "tags: {duckybot: {id: 1, size_mm: 25}}\n"
    )
    tree = tmp_path / "t.yaml"
    tree.write_text("root:\n  sweep: {tag: duckybot}\n")
    with pytest.raises(armtree.ConfigError) as info:
        armtree.load_tree(tree, rig=profile)
    messages = [f"{e.line}:{e.column}: {e.message}" for e in info.value.errors]
    assert any(m.startswith("2:3: sweep needs workcell.survey") for m in messages), messages


def test_clean_up_needs_the_survey_only_when_it_sweeps_and_check_says_so_at_load(tmp_path, capsys):
    from armtree.cli import commandline as cli

    profile = tmp_path / "rig.yaml"
    profile.write_text(
        "arm: {type: vicra}\ncamera: {type: sim}\ntracker: {type: aruco}\n"
        "places: {garbage_bin: [0, 300, 100]}\ntags: {trash: {ids: [2], size_mm: 25}}\n"
    )
    here = tmp_path / "here.yaml"
    here.write_text("root:\n  clean_up: {}\n")
    assert cli.main(["check", str(here), "--rig", str(profile)]) == 0  # looks from where it is
    swept = tmp_path / "swept.yaml"
    swept.write_text("root:\n  sequence:\n    children:\n      - clean_up: {sweep: true}\n")
    assert cli.main(["check", str(swept), "--rig", str(profile)]) == 2
    err = capsys.readouterr().err
    assert f"{swept}:4:9: clean_up needs workcell.survey in the hardware profile" in err
