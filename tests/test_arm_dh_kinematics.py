"""DH arms: the slides' PUMA 560 and Motoman L-3 closed forms, conventions, DLS IK, bad tables."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from armtree.errors import ConfigError, Unreachable
from armtree.plugins.arms.dh.kinematics import DHModel, DHRow, model_from_config, parse_dh

# Aceves slides: PUMA 560 (modified DH), a2 = 431 mm, a3 = 20, d3 = 149, d4 = 433 (slides in m)
A2, A3, D3, D4 = 431.0, 20.0, 149.0, 433.0
PUMA = DHModel(
    [
        DHRow(0, 0, 0),
        DHRow(0, -90, 0),
        DHRow(A2, 0, D3),
        DHRow(A3, -90, D4),
        DHRow(0, 90, 0),
        DHRow(0, -90, 0),
    ],
    [(-180, 180)] * 6,
    "modified",
)
# Aceves slides: Motoman L-3, L2 = L3 = 500 mm
L2 = L3 = 500.0
MOTOMAN = DHModel(
    [DHRow(0, 0, 0), DHRow(0, -90, 0), DHRow(L2, 0, 0), DHRow(L3, 0, 0), DHRow(0, -90, 0)],
    [(-180, 180)] * 5,
    "modified",
)


def angles(n, lo=-170.0, hi=170.0):
    return st.lists(st.floats(lo, hi, allow_nan=False), min_size=n, max_size=n).map(np.array)


@settings(max_examples=100, deadline=None)
@given(angles(6))
def test_puma_matches_the_slides_closed_form(q):
    # Aceves slides, "La solución de la Cinemática Directa del Robot PUMA": Px, Py, Pz
    q1, q2, q3 = np.radians(q[:3])
    c1, s1, c2, s2 = np.cos(q1), np.sin(q1), np.cos(q2), np.sin(q2)
    c23, s23 = np.cos(q2 + q3), np.sin(q2 + q3)
    px = c1 * (A2 * c2 + A3 * c23 - D4 * s23) - D3 * s1
    py = s1 * (A2 * c2 + A3 * c23 - D4 * s23) + D3 * c1
    pz = -A3 * s23 - A2 * s2 - D4 * c23
    np.testing.assert_allclose(PUMA.position(q), [px, py, pz], atol=1e-9)
    # r13, r23, r33 of the slides
    q4, q5 = np.radians(q[3:5])
    c4, s4, c5, s5 = np.cos(q4), np.sin(q4), np.cos(q5), np.sin(q5)
    r13 = -c1 * (c23 * c4 * s5 + s23 * c5) - s1 * s4 * s5
    r33 = s23 * c4 * s5 - c23 * c5
    T = PUMA.fk(q)
    np.testing.assert_allclose([T[0, 2], T[2, 2]], [r13, r33], atol=1e-12)


@settings(max_examples=100, deadline=None)
@given(angles(5))
def test_motoman_matches_the_slides_closed_form(q):
    # Aceves slides: Px = c1 (L2 c2 + L3 c23), Pz = -(L2 s2 + L3 s23), r33 = c234 ... (T05)
    q1, q2, q3, q4 = np.radians(q[:4])
    c1, s1 = np.cos(q1), np.sin(q1)
    reach = L2 * np.cos(q2) + L3 * np.cos(q2 + q3)
    expected = [c1 * reach, s1 * reach, -(L2 * np.sin(q2) + L3 * np.sin(q2 + q3))]
    np.testing.assert_allclose(MOTOMAN.position(q), expected, atol=1e-9)


def test_standard_and_modified_tables_of_one_arm_agree():
    # a planar 2R arm: standard (a1 = 100, a2 = 80) and modified (a0 = 0, a1 = 100, tool 80)
    std = DHModel([DHRow(100, 0, 0), DHRow(80, 0, 0)], [(-180, 180)] * 2, "standard")
    mod = DHModel(
        [DHRow(0, 0, 0), DHRow(100, 0, 0)], [(-180, 180)] * 2, "modified", tool_offset=(80, 0, 0)
    )
    q = np.random.default_rng(2).uniform(-180, 180, (50, 2))
    np.testing.assert_allclose(std.fk(q), mod.fk(q), atol=1e-9)
    t = np.radians(q)
    x = 100 * np.cos(t[:, 0]) + 80 * np.cos(t.sum(1))
    np.testing.assert_allclose(std.position(q)[:, 0], x, atol=1e-9)


def test_prismatic_joint_and_link_frames():
    arm = DHModel(
        [DHRow(0, 0, 50, kind="prismatic"), DHRow(0, 90, 0)], [(0, 200), (-90, 90)], "modified"
    )
    np.testing.assert_allclose(arm.position(np.array([120.0, 0.0])), [0, 0, 170], atol=1e-9)
    q = np.random.default_rng(3).uniform(arm.lower, arm.upper, (3, 4, 2))
    frames = arm.link_frames(q)
    assert frames.shape == (3, 4, 4, 4, 4)
    np.testing.assert_allclose(frames[..., -1, :, :], arm.fk(q), atol=1e-9)


def test_batched_fk_equals_one_at_a_time_and_geometric_jacobian_matches():
    q = np.random.default_rng(4).uniform(-180, 180, (5000, 6))
    batch = PUMA.fk(q)
    np.testing.assert_allclose(batch[4321], PUMA.fk(q[4321]), atol=1e-9)
    J = PUMA.jacobian_geometric(q[7])
    np.testing.assert_allclose(np.radians(1) * J[:3], PUMA.jacobian(q[7]), atol=1e-4)


@settings(max_examples=10, deadline=None, derandomize=True)
@given(angles(6, -150, 150))
def test_puma_ik_solutions_reach_the_pose_and_contain_q_from_near(q):
    T = PUMA.fk(q)
    sols = PUMA.ik_all(T)
    good = sols[np.all(np.isfinite(sols), axis=-1)]
    for s in good:
        np.testing.assert_allclose(PUMA.fk(s)[:3, 3], T[:3, 3], atol=2e-3)
        np.testing.assert_allclose(PUMA.fk(s)[:3, :3], T[:3, :3], atol=1e-4)
    # seeded near q, the solver returns q itself (ik(fk(q)) contains q); away from the
    # wrist singularity (q5 = 0), where q4 and q6 are interchangeable, and the elbow one
    # (forearm and a3 in line, q3 = 90 - atan(a3 / d4)), where joint error hardly moves the pose
    assume(10 < abs(q[4]) < 140)
    elbow = 90.0 - np.degrees(np.arctan2(A3, D4))
    assume(abs(q[2] - elbow) > 10 and abs(q[2] - elbow + 180) > 10)
    near = PUMA.ik(T, near=q + 3.0)
    np.testing.assert_allclose(PUMA.fk(near), T, atol=2e-3)
    assert np.abs(near - q).max() < 0.05


def test_puma_ik_finds_several_solutions_including_q():
    q = np.array([10.0, 20.0, -30.0, 40.0, 50.0, 60.0])
    sols = PUMA.ik_all(PUMA.fk(q))
    good = sols[np.all(np.isfinite(sols), axis=-1)]
    assert len(good) >= 2
    assert np.abs(good - q).max(axis=-1).min() < 1e-2


def test_ik_batch_solves_most_random_targets_and_positions():
    q = np.random.default_rng(5).uniform(-170, 170, (200, 6))
    sols = PUMA.ik_batch(PUMA.fk(q))
    ok = np.all(np.isfinite(sols), axis=-1)
    assert ok.mean() > 0.9
    np.testing.assert_allclose(PUMA.fk(sols[ok]), PUMA.fk(q)[ok], atol=2e-3)
    # positions only (3 constraints) on the 5-joint Motoman
    qm = np.random.default_rng(6).uniform(-170, 170, (100, 5))
    p = MOTOMAN.position(qm)
    s = MOTOMAN.ik_batch(p)
    okm = np.all(np.isfinite(s), axis=-1)
    assert okm.mean() > 0.95
    np.testing.assert_allclose(MOTOMAN.position(s[okm]), p[okm], atol=2e-3)


def test_joint_limits_respected_and_unreachable_outside():
    arm = DHModel(
        [DHRow(0, 0, 0), DHRow(300, 0, 0)],
        [(-90, 90), (0, 90)],
        "modified",
        tool_offset=(200, 0, 0),
    )
    sols = arm.ik_all(np.array([0.0, 500.0, 0.0]))
    good = sols[np.all(np.isfinite(sols), axis=-1)]
    assert np.all(arm.within_limits(good))
    with pytest.raises(Unreachable, match="outside the workspace"):
        arm.ik(np.array([600.0, 0.0, 0.0]))
    with pytest.raises(Unreachable):
        arm.ik(np.array([-300.0, -10.0, 0.0]))  # needs q1 outside [-90, 90]
    with pytest.raises(Unreachable):
        PUMA.ik(np.array([np.nan, 0, 0]))


@pytest.mark.parametrize(
    ("dh", "match"),
    [
        ({"convention": "odd", "table": [{"a": 0}]}, "convention"),
        ({"table": []}, "non-empty"),
        ({"table": [{"a": "x"}]}, r"table\[0\]\.a"),
        ({"table": [{"a": 0, "type": "Q"}]}, "type"),
        ({"table": [{"a": 0, "limits": [10, -10]}]}, "limits"),
        ({"table": [{"a": 0, "bogus": 1}]}, "unknown"),
    ],
)
def test_bad_tables_are_config_errors(dh, match):
    with pytest.raises(ConfigError, match=match):
        parse_dh(dh)


def test_model_from_config_reads_tool_base_and_home():
    model = model_from_config(
        {
            "dh": {
                "convention": "standard",
                "table": [{"a": 100}],
                "tool_offset_mm": [10, 0, 0],
                "base_mm": [0, 0, 50],
                "home": [30],
            }
        }
    )
    np.testing.assert_allclose(model.position(np.array([0.0])), [110, 0, 50], atol=1e-9)
    assert model.home.tolist() == [30.0]
    with pytest.raises(ConfigError):
        model_from_config({"dh": {"table": [{"a": 1}], "home": [1, 2]}})


# -- a hobby arm holding its gripper vertical: tool_axis and the closed form ---------------

HOBBY = None


def hobby():
    """sim_dh's five-axis arm (base yaw, three pitch joints, roll; gripper pointing down)."""
    global HOBBY
    if HOBBY is None:
        from armtree.loader.profile import load_profile
        from armtree.plugins.arms.dh.plugin import dh_factory

        HOBBY = dh_factory.model(load_profile("sim_dh").component("arm"))
    return HOBBY


@settings(max_examples=40, deadline=None)
@given(
    st.floats(-85, 85),
    st.floats(5, 155),
    st.floats(-155, -5),
)
def test_hobby_arm_closed_form_contains_every_pointing_down_configuration(q1, q2, q3):
    # for sim_dh's table the gripper points straight down when q2 + q3 + q4 = -90
    model = hobby()
    q = np.array([q1, q2, q3, -90.0 - q2 - q3, 0.0])
    assume(bool(model.within_limits(q)))
    tool = model.fk(q)
    np.testing.assert_allclose(tool[:3, 2], [0, 0, -1], atol=1e-9)
    sols = model.ik_all(tool[:3, 3])
    good = sols[np.all(np.isfinite(sols), axis=-1)]
    assert np.abs(good - q).max(axis=-1).min() < 1e-6
    reached = model.fk(good)
    np.testing.assert_allclose(
        reached[:, :3, 3], np.broadcast_to(tool[:3, 3], (len(good), 3)), atol=1e-6
    )
    np.testing.assert_allclose(
        reached[:, :3, 2], np.broadcast_to([0, 0, -1], (len(good), 3)), atol=1e-9
    )
    assert np.all(model.within_limits(good))


def test_hobby_arm_closed_form_agrees_with_damped_least_squares():
    model = hobby()
    assert model.planar is not None and PUMA.planar is None and MOTOMAN.planar is None
    points = np.random.default_rng(9).uniform([-100, -300, 0], [350, 300, 250], (150, 3))
    closed = np.isfinite(model.ik_all(points)).all(-1).any(-1)
    numeric = DHModel(
        model.rows,
        list(zip(model.lower, model.upper, strict=True)),
        name="numeric",
        tool_offset=model.tool_offset,
        home=model.home,
        tool_axis=[0, 0, -2],  # the same axis, unnormalised
    )
    numeric.planar = None
    dls = numeric.ik_all(points)
    found = np.isfinite(dls).all(-1)
    assert 40 < closed.sum() < 110
    np.testing.assert_array_equal(found.any(-1), closed)
    axis = numeric.fk(dls[found])[:, :3, 2]
    np.testing.assert_allclose(axis, np.broadcast_to([0, 0, -1], axis.shape), atol=1e-5)
    # one solution per target, the nearest to the given joints
    one = model.ik_batch(points, near=model.home)
    assert np.array_equal(np.isfinite(one).all(-1), closed)


def test_tool_axis_and_boxes_from_a_profile_are_checked():
    base = {"table": [{"a": 0, "alpha": 0, "d": 50}, {"a": 100}]}
    with pytest.raises(ConfigError, match="tool_axis"):
        model_from_config({"dh": {**base, "tool_axis": [0, 0, 0]}})
    with pytest.raises(ConfigError, match="tool_boxes_mm"):
        model_from_config({"dh": {**base, "tool_boxes_mm": [{"size": [10, 10]}]}})
    with pytest.raises(ConfigError, match="max_speed"):
        model_from_config({"dh": {"table": [{"a": 0, "max_speed": -1}]}})
    model = model_from_config(
        {
            "dh": {
                **base,
                "tool_boxes_mm": [{"name": "cup", "size": [10, 10, 30]}],
                "link_width_mm": 20,
            }
        }
    )
    assert [b.name for b in model.boxes] == ["link0", "link1", "cup"]
    assert model.boxes[0].size[0] == 20.0
