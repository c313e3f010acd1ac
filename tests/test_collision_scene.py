"""Scenes from profiles (boxes, STL/OBJ meshes, table, places) and the arm collision checker."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from planning_models import PlanarArm, wide_dobot

from armtree.errors import ConfigError
from armtree.maths.motion.collision import CollisionChecker, obb_overlap
from armtree.maths.motion.geometry import box_corners, box_triangles, from_rpy_deg, transform
from armtree.maths.motion.meshio import load_mesh, write_stl_ascii, write_stl_binary
from armtree.maths.motion.scene import Scene
from armtree.maths.motion.tritri import intersect_matrix

WALL = {"box": {"center": [0, 250, 50], "size": [400, 20, 300], "name": "wall"}}


def _cube(center, size):
    return box_triangles(transform(None, np.array(center, float)), np.array([size] * 3, float))


# -- boxes: SAT against a brute-force reference ---------------------------------


def _overlap_reference(pa, sa, pb, sb):
    """Surfaces cross, or one box holds a corner of the other."""
    if intersect_matrix(box_triangles(pa, sa), box_triangles(pb, sb)).any():
        return True
    for p, s, corners in ((pa, sa, box_corners(pb, sb)), (pb, sb, box_corners(pa, sa))):
        local = (corners - p[:3, 3]) @ p[:3, :3]
        if np.any(np.all(np.abs(local) <= s / 2, axis=1)):
            return True
    return False


@settings(max_examples=150, deadline=None)
@given(
    st.lists(st.floats(-180, 180), min_size=6, max_size=6),
    st.lists(st.floats(-3, 3), min_size=3, max_size=3),
    st.lists(st.floats(0.3, 2.5), min_size=6, max_size=6),
)
def test_obb_sat_matches_triangle_reference(angles, offset, sizes):
    pa = transform(from_rpy_deg(np.array(angles[:3])), np.zeros(3))
    pb = transform(from_rpy_deg(np.array(angles[3:])), np.array(offset))
    sa, sb = np.array(sizes[:3]), np.array(sizes[3:])
    fast = obb_overlap(pa[:3, 3], pa[:3, :3], sa / 2, pb[:3, 3], pb[:3, :3], sb / 2, tol=0.0)
    assert bool(fast) == _overlap_reference(pa, sa, pb, sb)


def test_obb_overlap_broadcasts():
    c = np.array([[0, 0, 0], [5, 0, 0], [1.5, 0, 0.0]])
    hit = obb_overlap(c[:, None], np.eye(3), np.ones(3), np.zeros((1, 3)), np.eye(3), np.ones(3))
    assert hit.shape == (3, 1)
    np.testing.assert_array_equal(hit[:, 0], [True, False, True])


# -- scene from a profile ----------------------------------------------------------


def test_scene_from_profile_with_boxes_meshes_and_places(tmp_path):
    write_stl_ascii(tmp_path / "block.stl", _cube([0, 0, 0], 20))
    write_stl_binary(tmp_path / "block_bin.stl", _cube([0, 0, 0], 20))
    (tmp_path / "tri.obj").write_text(
        "# one quad\nv 0 0 0\nv 10 0 0\nv 10 10 0\nv 0 10 0\nf 1 2 3 4\n"
    )
    profile = {
        "table": {"z": -5},
        "obstacles": [
            WALL,
            {"mesh": {"file": "block.stl", "position": [300, 0, 0]}},
            {"mesh": {"file": str(tmp_path / "block_bin.stl"), "rpy": [0, 0, 45], "scale": 2.0}},
            {"mesh": {"file": "tri.obj", "name": "tile"}},
        ],
        "places": {"home": [200, 0, 80], "bin": [60, -200, 40]},
    }
    scene = Scene.from_profile(profile, base_dir=tmp_path)
    assert scene.table_z == -5 and len(scene.boxes) == 1 and len(scene.meshes) == 3
    assert scene.meshes[0].triangles.shape == (12, 3, 3)
    np.testing.assert_allclose(scene.meshes[0].lower, [290, -10, -10])
    assert scene.meshes[2].triangles.shape == (2, 3, 3) and scene.meshes[2].name == "tile"
    np.testing.assert_allclose(np.ptp(scene.meshes[1].triangles.reshape(-1, 3), axis=0)[2], 40)
    assert scene.blocker_of([0, 250, 50]) == "obstacle 'wall'"
    assert scene.blocker_of([300, 0, 0]) == "mesh 'mesh1'"
    assert scene.blocker_of([0, 0, -10]) == "the table"
    assert scene.blocker_of([200, 0, 80]) is None
    assert scene.fingerprint() == Scene.from_profile(profile, base_dir=tmp_path).fingerprint()


def test_binary_and_ascii_stl_agree(tmp_path):
    tris = _cube([1, 2, 3], 4)
    write_stl_ascii(tmp_path / "a.stl", tris)
    write_stl_binary(tmp_path / "b.stl", tris)
    np.testing.assert_allclose(
        load_mesh(tmp_path / "a.stl"), load_mesh(tmp_path / "b.stl"), atol=1e-5
    )


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("bad.stl", b"solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0\n", "bad vertex line"),
        ("bad.stl", b"\x00\x01garbage\xff" * 3, "not a valid STL"),
        ("empty.stl", b"solid empty\nendsolid empty\n", "no triangles"),
        ("bad.obj", b"v 0 0 0\nv 1 0 0\nf 1 2 7\n", "does not exist"),
        ("bad.obj", b"v 0 zero 0\n", "bad OBJ line"),
        ("mesh.ply", b"ply\n", "unsupported mesh format"),
    ],
)
def test_meshes_that_fail_to_load_raise_config_error(tmp_path, name, content, message):
    (tmp_path / name).write_bytes(content)
    with pytest.raises(ConfigError, match=message) as err:
        Scene.from_profile({"obstacles": [{"mesh": {"file": name}}]}, base_dir=tmp_path)
    assert name in str(err.value)


def test_missing_mesh_file_and_degenerate_mesh(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        Scene.from_profile({"obstacles": [{"mesh": {"file": "nope.stl"}}]}, base_dir=tmp_path)
    (tmp_path / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    with pytest.raises(ConfigError, match="degenerate"):
        Scene.from_profile({"obstacles": [{"mesh": {"file": "flat.obj"}}]}, base_dir=tmp_path)


@pytest.mark.parametrize(
    ("obstacles", "message"),
    [
        ([{"box": {"center": [0, 0, 0], "size": [10, 0, 10]}}], "degenerate box"),
        ([{"box": {"center": [0, 0], "size": [1, 1, 1]}}], "exactly 3"),
        ([{"box": {"center": [0, 0, float("nan")], "size": [1, 1, 1]}}], "finite"),
        ([{"box": {"centre": [0, 0, 0], "size": [1, 1, 1]}}], "unknown key"),
        ([{"cone": {}}], "unknown obstacle kind"),
        ([{"sphere": {"center": [0, 0, 0], "radius": 0}}], "must be > 0"),
        ([{"table": {"height": 3}}], "expected"),
        ("wall", "must be a list"),
    ],
)
def test_bad_obstacles_raise_config_error(obstacles, message):
    with pytest.raises(ConfigError, match=message):
        Scene.from_profile({"obstacles": obstacles})


def test_place_inside_an_obstacle_is_refused():
    with pytest.raises(ConfigError, match="place 'bin'.*inside obstacle 'wall'"):
        Scene.from_profile({"obstacles": [WALL], "places": {"bin": [0, 250, 40]}})
    with pytest.raises(ConfigError, match="place 'floor'.*the table"):
        Scene.from_profile({"table": {"z": 0}, "places": {"floor": [100, 0, -1]}})


def test_profile_objects_with_a_data_mapping_are_accepted():
    class FakeProfile:
        source = "/somewhere/rig.yaml"
        data = {"obstacles": [WALL], "places": {}}

    scene = Scene.from_profile(FakeProfile())
    assert scene.source == "/somewhere/rig.yaml" and scene.boxes[0].name == "wall"


# -- the checker -----------------------------------------------------------------------


@pytest.fixture
def dobot_scene():
    return Scene.from_profile({"table": {"z": -110}, "obstacles": [WALL]})


def test_collides_single_and_batch_agree(dobot_scene):
    model = wide_dobot()
    checker = CollisionChecker(model, dobot_scene)
    rng = np.random.default_rng(3)
    q = model.lower + rng.random((400, 3)) * (model.upper - model.lower)
    batch = checker.collides(q)
    assert batch.shape == (400,) and 0 < batch.mean() < 1
    singles = np.array([checker.collides(x) for x in q[:60]])
    np.testing.assert_array_equal(batch[:60], singles)
    assert isinstance(checker.collides(q[0]), bool)


def test_wall_table_and_self_collisions_are_named(dobot_scene):
    model = wide_dobot()
    checker = CollisionChecker(model, dobot_scene)
    toward_wall = np.array([90.0, 30.0, 20.0])
    assert checker.collides(toward_wall)
    assert {c.other for c in checker.contacts(toward_wall)} == {"obstacle 'wall'"}
    down = np.array([0.0, 85.0, 85.0])
    assert "the table" in {c.other for c in checker.contacts(down)}
    assert not checker.collides(model.home)
    # Upper arm upright, forearm pointing down: the end effector folds back onto the arm.
    free_space = CollisionChecker(model, Scene())
    folded = np.array([0.0, -10.0, 85.0])
    assert free_space.collides(folded)
    assert all("self-collision" in str(c) for c in free_space.contacts(folded))
    assert not free_space.collides(model.home)


def test_mesh_obstacle_blocks_the_arm(tmp_path):
    write_stl_binary(tmp_path / "pillar.stl", _cube([0, 0, 0], 40))
    model = PlanarArm()
    scene = Scene.from_profile(
        {"obstacles": [{"mesh": {"file": "pillar.stl", "position": [250, 0, 50]}}]},
        base_dir=tmp_path,
    )
    checker = CollisionChecker(model, scene)
    assert checker.collides(np.array([0.0, 0.0]))  # the stretched arm passes through the pillar
    assert not checker.collides(np.array([90.0, 0.0]))
    assert checker.contacts(np.array([0.0, 0.0]))[0].other == "a mesh obstacle"
    # A mesh small enough to sit wholly inside a link box still collides.
    write_stl_ascii(tmp_path / "pebble.stl", _cube([0, 0, 0], 2))
    inside = Scene.from_profile(
        {"obstacles": [{"mesh": {"file": "pebble.stl", "position": [100, 0, 50]}}]},
        base_dir=tmp_path,
    )
    assert CollisionChecker(model, inside).collides(np.array([0.0, 0.0]))


def test_segment_free_checks_between_the_ends(dobot_scene):
    model = wide_dobot()
    checker = CollisionChecker(model, dobot_scene)
    a, b = np.array([30.0, 30.0, 20.0]), np.array([130.0, 30.0, 20.0])
    assert not checker.collides(a) and not checker.collides(b)
    assert not checker.segment_free(a, b, step_deg=2.0)  # sweeps through the wall at 90 deg
    assert checker.segment_free(np.array([-60.0, 30.0, 20.0]), np.array([0.0, 30.0, 20.0]))
    free = checker.segments_free(np.stack([a, a]), np.stack([b, np.array([0.0, 30.0, 20.0])]), 2.0)
    np.testing.assert_array_equal(free, [False, True])
    with pytest.raises(ValueError):
        checker.segment_free(a, b, step_deg=0)


def test_start_overlapping_an_obstacle_is_a_config_error():
    model = wide_dobot()
    scene = Scene.from_profile(
        {"obstacles": [{"box": {"center": [240, 0, 140], "size": [60, 60, 60], "name": "crate"}}]}
    )
    with pytest.raises(ConfigError, match="home configuration.*crate"):
        CollisionChecker(model, scene).check_start(np.array([0.0, 20.0, 10.0]), "home")
    on_base = Scene.from_profile(
        {"obstacles": [{"box": {"center": [0, 0, -60], "size": [30, 30, 30], "name": "brick"}}]}
    )
    with pytest.raises(ConfigError, match="brick.*fixed part 'base'"):
        CollisionChecker(model, on_base)


def test_cylinders_and_spheres_are_enclosing_meshes():
    scene = Scene.from_profile(
        {
            "obstacles": [
                {"cylinder": {"center": [0, 0, 50], "radius": 20, "height": 100, "name": "post"}},
                {"sphere": {"center": [100, 0, 0], "radius": 10, "name": "ball"}},
            ]
        }
    )
    post, ball = scene.meshes
    rng = np.random.default_rng(0)
    p = rng.uniform(-1, 1, (4000, 3)) * [25, 25, 60] + [0, 0, 50]
    in_cylinder = (np.hypot(p[:, 0], p[:, 1]) < 20) & (np.abs(p[:, 2] - 50) < 50)
    assert np.all(post.contains(p)[in_cylinder])  # never smaller than the cylinder
    q = rng.uniform(-12, 12, (4000, 3)) + [100, 0, 0]
    assert np.all(ball.contains(q)[np.linalg.norm(q - [100, 0, 0], axis=1) < 10])
    assert scene.blocker_of([0, 0, 50]) == "mesh 'post'"
    assert scene.blocker_of([100, 0, 11.5]) is None  # the faceting adds at most a few percent


def test_errors_carry_the_profile_position(tmp_path):
    from armtree.loader.profile import load_profile

    path = tmp_path / "rig.yaml"
    path.write_text(
        "profile: rig\n"
        "arm: {type: dobot_v1, port: sim}\n"
        "obstacles:\n"
        "  - box: {center: [0, 250, 50], size: [400, 20, 300]}\n"
        "  - mesh: {file: missing.stl, scale: -1}\n"
    )
    # load_profile builds the scene while it validates, so the error surfaces there.
    with pytest.raises(ConfigError) as err:
        load_profile(path)
    assert any(e.line == 5 and "obstacles[1].mesh.scale" in e.message for e in err.value.errors)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.lists(
            st.lists(st.floats(-1e4, 1e4, allow_nan=False, width=32), min_size=3, max_size=3),
            min_size=3,
            max_size=3,
        ),
        min_size=1,
        max_size=20,
    ),
    st.sampled_from(["ascii", "binary", "obj"]),
)
def test_property_mesh_files_round_trip(tmp_path_factory, triangles, kind):
    tris = np.array(triangles, dtype=np.float32).astype(float)
    path = tmp_path_factory.mktemp("mesh") / ("m.obj" if kind == "obj" else "m.stl")
    if kind == "ascii":
        write_stl_ascii(path, tris)
    elif kind == "binary":
        write_stl_binary(path, tris)
    else:
        verts = tris.reshape(-1, 3)
        lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in verts.tolist()]
        lines += [f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}" for k in range(len(tris))]
        path.write_text("\n".join(lines) + "\n")
    np.testing.assert_allclose(load_mesh(path), tris, rtol=1e-6, atol=1e-6)


def test_binary_stl_whose_header_says_solid(tmp_path):
    write_stl_binary(tmp_path / "b.stl", _cube([0, 0, 0], 2))
    data = bytearray((tmp_path / "b.stl").read_bytes())
    data[:11] = b"solid cube "
    (tmp_path / "b.stl").write_bytes(bytes(data))
    assert load_mesh(tmp_path / "b.stl").shape == (12, 3, 3)


def test_margin_grows_moving_boxes_only():
    model = wide_dobot()
    table = Scene.from_profile(
        {"obstacles": [{"box": {"center": [0, 0, -105], "size": [800, 800, 10], "name": "table"}}]}
    )
    # The base still stands on the table: a margin does not grow what never moves.
    assert not CollisionChecker(model, table, margin=10.0).collides(model.home)
    near_wall = Scene.from_profile({"obstacles": [WALL]})
    reach = np.stack([np.array([90.0, t1, 50.0]) for t1 in np.linspace(0, 40, 41)])
    plain = CollisionChecker(model, near_wall).collides(reach)
    grown = CollisionChecker(model, near_wall, margin=8.0).collides(reach)
    assert plain.any() and not plain.all()
    assert grown.sum() > plain.sum() and np.all(grown[plain])
