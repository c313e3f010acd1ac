"""The direct and prm planners: valid paths, clear refusals, the roadmap cache, registration."""

import numpy as np
import pytest
from planning_models import PlanarArm, wide_dobot

from armtree.api.rig import RigContext
from armtree.errors import ConfigError, PlanningError, Unreachable
from armtree.hooks.plugin_manager import make_plugin_manager
from armtree.maths.motion.collision import CollisionChecker
from armtree.maths.motion.scene import Scene
from armtree.maths.motion.validation import validate_samples
from armtree.plugins.planners.direct import DirectPlanner, direct_factory, sample_segment
from armtree.plugins.planners.prm import PRMPlanner, Roadmap, default_cache_dir, prm_factory

WALL = {"box": {"center": [0, 250, 50], "size": [400, 20, 300], "name": "wall"}}
PROFILE = {"table": {"z": -110}, "obstacles": [WALL]}


@pytest.fixture(scope="module")
def checker():
    return CollisionChecker(wide_dobot(), Scene.from_profile(PROFILE))


def _path_is_valid(checker, path, step=0.5):
    for a, b in zip(path[:-1], path[1:], strict=True):
        assert validate_samples(checker, sample_segment(a, b, step)).ok


def _prm(checker, tmp_path, **kw):
    args = {"milestones": 300, "neighbours": 6, "seed": 4, "resolution": 2.0, "cache_dir": tmp_path}
    args.update(kw)
    return PRMPlanner(checker, **args)


# -- direct ------------------------------------------------------------------------


def test_direct_returns_the_straight_move_when_it_is_free(checker):
    planner = DirectPlanner(checker)
    start, goal = np.array([-60.0, 20.0, 30.0]), np.array([30.0, 30.0, 40.0])
    path = planner.plan(start, goal)
    np.testing.assert_allclose(path, [start, goal], atol=1e-9)


@pytest.mark.parametrize(
    ("goal", "reason"),
    [
        ([130.0, 30.0, 20.0], "collision"),  # sweeps through the wall
        ([90.0, 30.0, 20.0], "goal_in_collision"),
        ([0.0, 95.0, 20.0], "outside_limits"),
        ([0.0, float("nan"), 20.0], "not_finite"),
        ([0.0, 20.0], "bad_shape"),
    ],
)
def test_direct_refuses_with_a_reason(checker, goal, reason):
    with pytest.raises(PlanningError) as err:
        DirectPlanner(checker).plan(np.array([30.0, 30.0, 20.0]), np.array(goal))
    assert err.value.reason == reason


def test_direct_refuses_singular_goals():
    planar = CollisionChecker(PlanarArm(), Scene())
    with pytest.raises(PlanningError, match="singularity") as err:
        DirectPlanner(planar, min_singular=0.5).plan(np.array([0.0, 90.0]), np.array([0.0, 0.0]))
    assert err.value.reason == "singular"
    assert (
        len(
            DirectPlanner(planar, min_singular=None).plan(
                np.array([0.0, 90.0]), np.array([0.0, 0.0])
            )
        )
        == 2
    )


def test_direct_plan_to_tries_ik_solutions_nearest_first_and_refuses_nan():
    model = PlanarArm()
    planner = DirectPlanner(CollisionChecker(model, Scene()))
    target = model.position(np.array([30.0, 60.0]))
    path = planner.plan_to(np.array([25.0, 50.0]), target)
    np.testing.assert_allclose(path[-1], [30.0, 60.0], atol=1e-6)  # the elbow on the start's side
    path = planner.plan_to(np.array([90.0, -50.0]), target)
    np.testing.assert_allclose(model.position(path[-1]), target, atol=1e-6)
    assert path[-1][1] < 0
    with pytest.raises(Unreachable, match="not a finite"):
        planner.plan_to(np.array([0.0, 90.0]), np.array([np.nan, 0.0, 50.0]))
    with pytest.raises(Unreachable):
        planner.plan_to(np.array([0.0, 90.0]), np.array([900.0, 0.0, 50.0]))


# -- prm ------------------------------------------------------------------------------


def test_prm_goes_around_the_wall(checker, tmp_path):
    planner = _prm(checker, tmp_path)
    start, goal = np.array([30.0, 30.0, 20.0]), np.array([130.0, 30.0, 20.0])
    assert not checker.segment_free(start, goal)
    path = planner.plan(start, goal)
    np.testing.assert_allclose(path[0], start, atol=1e-9)
    np.testing.assert_allclose(path[-1], goal, atol=1e-9)
    assert len(path) >= 3
    _path_is_valid(checker, path)


def test_prm_cache_is_reused_and_rebuilt_when_the_scene_changes(checker, tmp_path):
    first = _prm(checker, tmp_path)
    roadmap = first.build()
    assert not first.loaded_from_cache and first.cache_path.exists()
    again = _prm(checker, tmp_path)
    again.build()
    assert again.loaded_from_cache
    np.testing.assert_array_equal(again.roadmap.nodes, roadmap.nodes)
    moved = Scene.from_profile(
        {"table": {"z": -110}, "obstacles": [{"box": {**WALL["box"], "center": [0, 260, 50]}}]}
    )
    other = _prm(CollisionChecker(checker.model, moved), tmp_path)
    other.build()
    assert not other.loaded_from_cache and other.cache_path != first.cache_path
    # Different limits: a different model fingerprint, a different roadmap.
    narrow = _prm(
        CollisionChecker(
            wide_dobot().__class__(lower=(-90, 0, 0), upper=(90, 80, 80), coupled=None),
            Scene.from_profile(PROFILE),
        ),
        tmp_path,
    )
    assert narrow.key != first.key


def test_prm_is_reproducible_for_a_seed(checker, tmp_path):
    a = _prm(checker, tmp_path / "a").build()
    b = _prm(checker, tmp_path / "b").build()
    c = _prm(checker, tmp_path / "c", seed=5).build()
    np.testing.assert_array_equal(a.nodes, b.nodes)
    np.testing.assert_array_equal(a.edges, b.edges)
    assert not np.array_equal(a.nodes, c.nodes)
    assert checker.valid(a.nodes).all()
    assert checker.segments_free(a.nodes[a.edges[:, 0]], a.nodes[a.edges[:, 1]], 2.0).all()


def test_corrupt_cache_file_is_rebuilt(checker, tmp_path):
    planner = _prm(checker, tmp_path)
    planner.cache_path.parent.mkdir(parents=True, exist_ok=True)
    planner.cache_path.write_bytes(b"not a roadmap")
    planner.build()
    assert not planner.loaded_from_cache
    assert Roadmap.load(planner.cache_path, planner.key) is not None


def test_prm_refusals_name_the_reason(checker, tmp_path):
    planner = _prm(checker, tmp_path)
    ok = np.array([30.0, 30.0, 20.0])
    cases = [
        (np.array([90.0, 30.0, 20.0]), "goal_in_collision"),
        (np.array([0.0, 30.0, 120.0]), "outside_limits"),
        (np.array([np.inf, 30.0, 20.0]), "not_finite"),
    ]
    for goal, reason in cases:
        with pytest.raises(PlanningError) as err:
            planner.plan(ok, goal)
        assert err.value.reason == reason
    with pytest.raises(PlanningError) as err:
        planner.plan(np.array([90.0, 30.0, 20.0]), ok)
    assert err.value.reason == "start_in_collision"


def test_prm_reports_a_disconnected_roadmap(tmp_path):
    # A wall across the whole reach cuts the joint space in two halves.
    model = PlanarArm()
    scene = Scene.from_profile(
        {"obstacles": [{"box": {"center": [0, 220, 50], "size": [20, 390, 200], "name": "wall"}}]}
    )
    checker = CollisionChecker(model, scene)
    planner = PRMPlanner(checker, milestones=200, neighbours=5, cache_dir=None)
    with pytest.raises(PlanningError, match="different components") as err:
        planner.plan(np.array([-30.0, 0.0]), np.array([160.0, 0.0]))
    assert err.value.reason == "disconnected"


def test_prm_with_few_milestones_is_a_config_error(checker):
    with pytest.raises(ConfigError):
        PRMPlanner(checker, milestones=1)


def test_progress_bar_can_be_forced_on_and_off(checker, monkeypatch):
    from rich.progress import Progress

    updates = []
    update = Progress.update

    def record(self, task, **fields):
        updates.append((fields.get("completed"), fields.get("total")))
        return update(self, task, **fields)

    monkeypatch.setattr(Progress, "update", record)
    shown = PRMPlanner(checker, milestones=50, neighbours=3, cache_dir=None, progress=True).build()
    assert updates and updates[-1][0] == updates[-1][1] > 0, "the bar ends full"
    assert [done for done, _ in updates] == sorted(done for done, _ in updates)
    updates.clear()
    hidden = PRMPlanner(checker, milestones=50, neighbours=3, cache_dir=None, progress=False)
    np.testing.assert_array_equal(hidden.build().edges, shown.edges)
    assert updates == [], "progress=False draws no bar"


# -- cached roadmaps are not trusted -----------------------------------------------------


def test_an_edited_cache_cannot_make_a_path_through_an_obstacle(checker, tmp_path):
    built = _prm(checker, tmp_path)
    roadmap = built.build()
    start, goal = np.array([30.0, 30.0, 20.0]), np.array([130.0, 30.0, 20.0])
    assert not checker.segment_free(start, goal)  # the wall lies between them
    # Edit the cache: milestones at start and goal joined by a free-looking edge of length 0.
    nodes = np.vstack([roadmap.nodes, start, goal])
    s, g = len(nodes) - 2, len(nodes) - 1
    edges = np.vstack([roadmap.edges, [[s, g]]])
    weights = np.append(roadmap.weights, 0.0)
    Roadmap(nodes, edges, weights, roadmap.key).save(built.cache_path)
    cached = _prm(checker, tmp_path, smooth=False)
    cached.build()
    assert cached.loaded_from_cache
    path = cached.plan(start, goal)
    _path_is_valid(checker, path)


def test_a_cached_milestone_inside_an_obstacle_makes_the_roadmap_rebuild(checker, tmp_path):
    built = _prm(checker, tmp_path)
    roadmap = built.build()
    nodes = roadmap.nodes.copy()
    nodes[0] = [90.0, 30.0, 20.0]  # in the wall
    Roadmap(nodes, roadmap.edges, roadmap.weights, roadmap.key).save(built.cache_path)
    again = _prm(checker, tmp_path)
    again.build()
    assert not again.loaded_from_cache
    assert bool(np.all(checker.valid(again.roadmap.nodes)))


# -- factories and registration ---------------------------------------------------------


def test_planners_are_registered_and_factories_build(tmp_path):
    registry = make_plugin_manager(autoload=False).registry
    assert registry.get("planner", "prm").factory is prm_factory
    assert registry.get("planner", "direct").factory is direct_factory
    ctx = RigContext(profile=None, clock=None)
    scene = Scene.from_profile(PROFILE)
    prm = prm_factory({"type": "prm", "milestones": 100, "neighbours": 4}, ctx, wide_dobot(), scene)
    # Roadmaps go to the user's cache folder, never to a path a YAML file names.
    assert prm.milestones == 100 and prm.cache_dir == default_cache_dir()
    assert direct_factory({"type": "direct"}, ctx, wide_dobot(), scene).resolution == 2.0
    assert {p.name for p in prm_factory.PARAMS} >= {
        "milestones",
        "neighbours",
        "seed",
        "resolution_deg",
        "cache",
    }


def test_factory_refuses_a_home_inside_an_obstacle():
    scene = Scene.from_profile(
        {"obstacles": [{"box": {"center": [150, 0, 10], "size": [60, 60, 60], "name": "crate"}}]}
    )
    with pytest.raises(ConfigError, match="crate"):
        direct_factory({}, RigContext(profile=None, clock=None), wide_dobot(), scene)


# -- the real Dobot V1.0 model and a profile ------------------------------------------------


def test_prm_on_the_dobot_v1_model_from_a_profile(tmp_path):
    from armtree.loader.profile import load_profile
    from armtree.plugins.arms.dobot_v1.kinematics import DobotV1Model
    from armtree.runtime.rig_builder import make_scene

    rig = tmp_path / "rig.yaml"
    rig.write_text(
        "profile: rig\n"
        # A real port (never opened here): the sim would refuse the 800 mm table box.
        "arm: {type: dobot_v1, port: /dev/ttyUSB0}\n"
        "planner: {type: prm, milestones: 400, neighbours: 5, seed: 2}\n"
        "places: {home: [185, 0, 30]}\n"
        "obstacles:\n"
        "  - box: {center: [0, 0, -105], size: [800, 800, 10], name: table}\n"
        "  - box: {center: [0, 170, 0], size: [400, 20, 200], name: wall}\n"
    )
    profile = load_profile(rig)
    scene = make_scene(profile)
    assert isinstance(scene, Scene) and {b.name for b in scene.boxes} == {"table", "wall"}
    config = dict(profile.component("planner"), cache=False)
    planner = prm_factory(config, RigContext(profile=profile, clock=None), DobotV1Model(), scene)
    model = planner.model
    start = np.array([-60.0, 20.0, 58.0])
    goal_xyz = model.position(np.array([40.0, 20.0, 58.0]))
    path = planner.plan_to(start, goal_xyz)
    np.testing.assert_allclose(model.position(path[-1]), goal_xyz, atol=1e-6)
    _path_is_valid(planner.checker, path)
    with pytest.raises(Unreachable, match="outside the reachable workspace"):
        planner.plan_to(start, np.array([0.0, 0.0, 500.0]))
    # Past the wall the straight move hits it; the roadmap retracts the arm to slip by.
    beyond = np.array([130.0, 20.0, 58.0])
    assert not planner.checker.segment_free(start, beyond)
    path = planner.plan(start, beyond)
    _path_is_valid(planner.checker, path)
    radius = np.hypot(*model.position(path)[:, :2].T)
    assert radius.min() < 150.0


def test_factories_need_an_arm_and_accept_a_raw_obstacle_list():
    ctx = RigContext(profile=None, clock=None)
    with pytest.raises(ConfigError, match="needs an arm"):
        prm_factory({"type": "prm"}, ctx, None, Scene())
    raw = [{"box": {"center": [0, 250, 50], "size": [400, 20, 300]}}]
    planner = direct_factory({"type": "direct"}, ctx, wide_dobot(), raw)
    assert len(planner.checker.scene.boxes) == 1


def test_concurrent_queries_share_the_roadmap_safely(checker, tmp_path):
    from concurrent.futures import ThreadPoolExecutor

    planner = _prm(checker, tmp_path)
    planner.build()
    pairs = [
        (np.array([30.0 - k, 30.0, 20.0]), np.array([130.0 + k, 30.0, 20.0])) for k in range(4)
    ]
    pairs = pairs * 2
    with ThreadPoolExecutor(4) as pool:
        paths = list(pool.map(lambda p: planner.plan(*p), pairs))
    for (start, goal), path in zip(pairs, paths, strict=True):
        np.testing.assert_allclose(path[[0, -1]], [start, goal], atol=1e-9)
        _path_is_valid(checker, path)
    assert set(planner._graph.nodes) == set(range(len(planner.roadmap.nodes)))


def test_a_start_pose_inside_an_obstacle_is_refused_at_rig_build():
    scene = Scene.from_profile(PROFILE)
    ctx = RigContext(profile={"arm": {"type": "x", "start_pose": [90.0, 30.0, 20.0]}}, clock=None)
    with pytest.raises(ConfigError, match=r"start \(arm.start_pose\).*wall"):
        prm_factory({"type": "prm"}, ctx, wide_dobot(), scene)
    ok = RigContext(profile={"arm": {"type": "x", "start_pose": [0.0, 30.0, 20.0]}}, clock=None)
    assert prm_factory({"type": "prm", "cache": False}, ok, wide_dobot(), scene).cache_dir is None
