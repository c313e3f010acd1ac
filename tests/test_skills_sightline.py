"""Whether the arm's links stand between a fixed camera and a point (eye-to-hand)."""

from types import SimpleNamespace

import numpy as np

from armtree.api.skill.arm import camera_over
from armtree.api.skill.reach import reachable
from armtree.api.skill.sightline import (
    hides,
    joints_out_of_view,
    out_of_view,
    segment_hits_boxes,
    shadow,
)
from armtree.api.skill.survey import survey_points
from armtree.config.workcell import workcell_of
from armtree.plugins.arms.vicra.kinematics import VicraModel


def test_a_segment_crosses_a_box_only_where_it_passes_through_it():
    box = np.eye(4)[None]
    box[0, :3, 3] = [10.0, 0.0, 0.0]
    turned = box.copy()
    turned[0, :3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]  # 90 deg about z
    half = np.array([[5.0, 1.0, 1.0]])
    start = np.array([10.0, -20.0, 0.0])
    assert segment_hits_boxes(start, np.array([10.0, 20.0, 0.0]), box, half)[0]
    assert not segment_hits_boxes(start, np.array([10.0, -1.5, 0.0]), box, half)[0]  # stops short
    assert not segment_hits_boxes(start + [7.0, 0, 0], np.array([17.0, 20.0, 0.0]), box, half)[0]
    # turned a quarter, the box is 2 mm wide along x and 10 mm along y
    assert not segment_hits_boxes(start + [2.0, 0, 0], np.array([12.0, 20.0, 0.0]), turned, half)[0]
    assert segment_hits_boxes(np.array([0.0, 4.0, 0.0]), np.array([20.0, 4.0, 0.0]), turned, half)[
        0
    ]
    # many ends at once: (N, 1, 3) against the boxes gives (N, B)
    ends = np.array([[10.0, 20.0, 0.0], [30.0, 20.0, 0.0]])[:, None, :]
    assert segment_hits_boxes(start, ends, box, half)[:, 0].tolist() == [True, False]


CAMERA = np.array([[1.0, 0, 0, 300], [0, -1.0, 0, 0], [0, 0, -1.0, 650], [0, 0, 0, 1]])
CELL = {"table_z_mm": 0, "look_height_mm": 100,
        "survey": {"ring": {"radius_mm": 185, "range_deg": [-100, 100], "step_deg": 5}}}  # fmt: skip


def vicra_skill(q):
    model = VicraModel()
    arm = SimpleNamespace(model=model, joints=lambda: q, pose=lambda: model.fk(q))
    camera = SimpleNamespace(mount="eye_to_hand", extrinsics=CAMERA)
    return SimpleNamespace(
        rig=SimpleNamespace(arm=arm, camera=camera, planner=None),
        workcell=workcell_of({"workcell": CELL}),
    )


def test_out_of_view_clears_the_links_from_the_line_of_sight_not_just_the_tool():
    # sim_vicra's camera and survey ring; the tool 100 mm over a target near the ring's end
    model = VicraModel()
    target = np.array([303.5, 180.2, 0.0])
    q = model.ik(target + [0, 0, 100])
    skill = vicra_skill(q)
    assert hides(model, q, CAMERA[:3, 3], target)
    here = model.position(q)
    poses = [
        camera_over(skill, p, 100.0) for p in survey_points(skill.workcell.survey, 0.0, here, 1)
    ]
    farthest = max(
        (p for p in poses if reachable(model, p)), key=lambda p: np.linalg.norm(p[:2] - target[:2])
    )
    assert hides(model, model.ik(farthest, near=q), CAMERA[:3, 3], target)  # distance alone fails
    away = out_of_view(skill, target)
    assert not hides(model, model.ik(away, near=q), CAMERA[:3, 3], target)
    # over every solution: the joints themselves, clear of the target's line of sight
    joints = joints_out_of_view(skill, target)
    assert not hides(model, joints, CAMERA[:3, 3], target)
    tool = model.position(joints)  # a pose of the survey ring, the camera 100 mm over it
    assert np.isclose(np.hypot(tool[0], tool[1]), 185.0, atol=1e-6) and np.isclose(tool[2], 100.0)


def test_the_arms_shadow_holds_the_point_under_its_tool():
    model = VicraModel()
    q = model.ik(np.array([200.0, 60.0, 100.0]))
    hidden = shadow(vicra_skill(q))
    assert len(hidden) and np.min(np.linalg.norm(hidden[:, :2] - [200.0, 60.0], axis=1)) < 10.0
    assert (
        np.min(np.linalg.norm(hidden[:, :2] - [450.0, -150.0], axis=1)) > 50.0
    )  # far from the arm
