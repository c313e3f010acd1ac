"""Arm models from URDF files (core/maths/motion/urdf.py): the shipped SO-101 and Koch, any other.

Forward kinematics agrees with yourdfpy's own (an outside implementation of the same
file); inverse kinematics finds what forward kinematics gives, within the joint limits;
every link's collision geometry becomes a box; and a file that cannot make an arm is a
ConfigError at its line and column, saying how to fix it.
"""

from __future__ import annotations

import numpy as np
import pytest
import yourdfpy
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.config.resolve import resolve
from armtree.errors import ConfigError, Unreachable
from armtree.maths.motion.urdf import load_urdf

ARMS = ("so101", "koch")


def shipped(name: str):
    return resolve(f"{name}.urdf", "profile")


@pytest.fixture(scope="module", params=ARMS)
def arm(request):
    path = shipped(request.param)
    model = load_urdf(path, "tcp", tool_axis=[0, 0, -1])
    reference = yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=False)
    return model, reference


def fractions(n: int):
    return st.lists(st.floats(0.0, 1.0), min_size=n, max_size=n)


@settings(max_examples=25, deadline=None)
@given(f=fractions(5))
def test_forward_kinematics_is_yourdfpys(arm, f):
    model, reference = arm
    q = model.lower + np.asarray(f) * (model.upper - model.lower)
    cfg = {j.name: float(np.radians(v)) for j, v in zip(model.joints, q, strict=True)}
    cfg |= {name: 0.0 for name in reference.actuated_joint_names if name not in cfg}
    reference.update_cfg(cfg)
    expected = reference.get_transform("tcp", "world")
    got = model.fk(q)
    # Two chains of float products (degrees here, radians there) agree to about 1e-8.
    np.testing.assert_allclose(got[:3, :3], expected[:3, :3], atol=1e-7)
    np.testing.assert_allclose(got[:3, 3], expected[:3, 3] * 1000.0, atol=1e-4)
    # every frame of the batch is the single answer
    batch = model.link_frames(np.stack([q, q]))
    np.testing.assert_allclose(batch[1], model.link_frames(q))


@settings(max_examples=25, deadline=None)
@given(f=fractions(5), nudge=fractions(5))
def test_inverse_kinematics_finds_a_pose_forward_kinematics_gave(arm, f, nudge):
    model, _ = arm
    q = model.lower + np.asarray(f) * (model.upper - model.lower)
    near = np.clip(q + (np.asarray(nudge) - 0.5) * 20.0, model.lower, model.upper)
    pose = model.fk(q)
    solved = model.ik(pose, near=near)  # a whole pose: position and orientation
    assert model.within_limits(solved)
    np.testing.assert_allclose(model.fk(solved)[:3, 3], pose[:3, 3], atol=0.1)
    np.testing.assert_allclose(model.fk(solved)[:3, :3], pose[:3, :3], atol=2e-3)


@pytest.mark.parametrize("name", ARMS)
def test_position_targets_keep_the_gripper_pointing_down(name):
    model = load_urdf(shipped(name), "tcp", tool_axis=[0, 0, -1])
    for target in ([150.0, 0.0, 40.0], [100.0, -80.0, 30.0], [90.0, 90.0, 60.0]):
        q = model.ik(np.array(target))
        assert model.within_limits(q)
        np.testing.assert_allclose(model.position(q), target, atol=0.1)
        np.testing.assert_allclose(model.fk(q)[:3, 2], [0, 0, -1], atol=1e-3)
    with pytest.raises(Unreachable, match="outside the workspace"):
        model.ik(np.array([900.0, 0.0, 40.0]))


@pytest.mark.parametrize("name", ARMS)
def test_every_link_is_boxes_and_the_jaws_leave_room_for_an_object(name):
    model = load_urdf(shipped(name), "tcp", tool_axis=[0, 0, -1])
    assert [j.name for j in model.joints] == [
        "shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll",
    ]  # fmt: skip
    assert len(model.boxes) >= 8 and all(min(b.size) > 5 for b in model.boxes)
    q = model.ik(np.array([150.0, 0.0, 40.0]))
    tip = model.position(q)
    poses = model.box_poses(q)
    # nothing but the jaws reaches down beside the tool centre; they stand 60 mm apart
    beside = [
        p[:3, 3] for b, p in zip(model.boxes, poses, strict=True)
        if p[2, 3] - 0.5 * np.abs(p[2, :3]) @ b.size < tip[2] + 20.0
        and np.linalg.norm(p[:2, 3] - tip[:2]) < 60.0
    ]  # fmt: skip
    assert len(beside) == 2
    assert np.linalg.norm(beside[0] - beside[1]) == pytest.approx(68.0, abs=0.5)
    assert model.self_collision_pairs, "the gripper can hit the upper arm"


# ------------------------------------------------------------------------- bad input


def write(tmp_path, text: str, name: str = "arm.urdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


TWO_LINKS = """<robot name="r">
  <link name="a"/>
  <link name="b"><collision><geometry>{geometry}</geometry></collision></link>
  <joint name="j" type="{kind}">
    <parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
    {limit}
  </joint>
</robot>
"""


def two_links(geometry='<box size="0.1 0.1 0.1"/>', kind="revolute", limit=None):
    limit = '<limit lower="-1" upper="1" velocity="1"/>' if limit is None else limit
    return TWO_LINKS.format(geometry=geometry, kind=kind, limit=limit)


def error_of(path, tool="b", **options) -> ConfigError:
    with pytest.raises(ConfigError) as caught:
        load_urdf(path, tool, **options)
    return caught.value


def test_a_file_that_is_not_xml_is_placed(tmp_path):
    exc = error_of(write(tmp_path, "<robot>\n  <link name='a'>\n</robot>\n"))
    assert (exc.file, exc.line) == (str(tmp_path / "arm.urdf"), 3)
    assert exc.column is not None and "not a URDF" in exc.message


def test_a_file_that_is_not_a_robot(tmp_path):
    exc = error_of(write(tmp_path, "<?xml version='1.0'?>\n<sdf/>\n"))
    assert (exc.line, exc.column) == (2, 1) and "not <robot>" in exc.message


def test_a_number_that_is_not_one(tmp_path):
    exc = error_of(write(tmp_path, two_links('<box size="0.1 0.1"/>')))
    assert exc.line == 3 and "expected 3 numbers" in exc.message


def test_no_link_called_the_tool_link(tmp_path):
    exc = error_of(write(tmp_path, two_links()), tool="gripper")
    assert exc.line == 1 and "no link called 'gripper'" in exc.message and "a, b" in exc.message


def test_no_chain_to_the_tool_link(tmp_path):
    path = write(tmp_path, two_links().replace("</robot>", '  <link name="c"/>\n</robot>'))
    exc = error_of(path, tool="c")
    assert exc.line == 8 and "no chain of moving joints leads to the tool link 'c'" in exc.message
    exc = error_of(path, tool="b", base_link="c")
    assert exc.line == 3 and "no chain of joints leads from 'c'" in exc.message


def test_a_joint_without_limits(tmp_path):
    exc = error_of(write(tmp_path, two_links(limit="")))
    assert (exc.line, exc.column) == (4, 3)
    assert "joint 'j' has no limits" in exc.message and "<limit lower=" in exc.message
    # a continuous joint needs none: it turns within +-180 degrees
    model = load_urdf(write(tmp_path, two_links(kind="continuous", limit=""), "c.urdf"), "b")
    assert (model.joints[0].lower, model.joints[0].upper) == (-180.0, 180.0)


def test_limits_the_wrong_way_round(tmp_path):
    exc = error_of(write(tmp_path, two_links(limit='<limit lower="1" upper="-1"/>')))
    assert exc.line == 6 and "lower limit 1 is not below upper -1" in exc.message


def test_a_missing_mesh_is_placed_and_a_box_is_enough(tmp_path):
    exc = error_of(write(tmp_path, two_links('<mesh filename="package://arm/meshes/b.stl"/>')))
    assert (exc.line, exc.column) == (3, 39)
    assert "mesh file 'package://arm/meshes/b.stl' not found" in exc.message
    assert '<box size="x y z"/>' in exc.message


def test_a_mesh_that_is_there_gives_the_box_around_it(tmp_path):
    trimesh = pytest.importorskip("trimesh", reason="yourdfpy brings trimesh to read meshes")
    (tmp_path / "meshes").mkdir()
    trimesh.creation.box(extents=(0.02, 0.04, 0.06)).export(tmp_path / "meshes" / "b.stl")
    model = load_urdf(write(tmp_path, two_links('<mesh filename="meshes/b.stl"/>')), "b")
    np.testing.assert_allclose(model.boxes[0].size, (20.0, 40.0, 60.0), atol=1e-6)


def test_a_floating_joint_is_not_an_arms(tmp_path):
    exc = error_of(write(tmp_path, two_links(kind="floating")))
    assert exc.line == 4 and "is floating" in exc.message
