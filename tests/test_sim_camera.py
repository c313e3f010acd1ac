"""The sim camera renders markers where a real camera would see them, on the run's clock."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from sim_fakes import C270, FakeEmulator

from armtree.api.clock import VirtualClock
from armtree.api.rig import RigContext
from armtree.errors import ConfigError
from armtree.plugins.sim.camera import sim_camera
from armtree.plugins.sim.drawing import world_drawables
from armtree.plugins.sim.renderer import Renderer
from armtree.plugins.sim.world import world_for
from armtree.plugins.trackers.hamming import HammingTracker

STAND = {
    "mount": "eye_to_hand",
    "width": 640,
    "height": 480,
    "intrinsics": {"fx": 600.0, "fy": 600.0, "cx": 320.0, "cy": 240.0},
    "position": [200, 0, 600],
    "look_at": [200, 0, 0],
}
PARAMS = cv2.aruco.DetectorParameters()
PARAMS.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
DETECTOR = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50), PARAMS)


@pytest.fixture
def rig(camera_profile):
    """A factory: clock, world, arm emulator (tool held at ``tool``) and sim camera."""

    def make(camera_config, seed=0, profile=None, tool=(183, -6, 200)):
        clock = VirtualClock()
        profile = camera_profile if profile is None else profile
        context = RigContext(profile=profile, clock=clock, seed=seed)
        world = world_for(context)
        emulator = FakeEmulator()
        emulator.put(tool)
        world.attach_arm(emulator)
        camera = sim_camera(dict(camera_config), context)
        return clock, world, emulator, camera

    return make


def detect(image):
    corners, ids, _ = DETECTOR.detectMarkers(image)
    if ids is None:
        return {}
    return {int(i): c.reshape(4, 2) for i, c in zip(ids.ravel(), corners, strict=True)}


def truth_corners(world, camera, name):
    body = world.bodies[name]
    s = body.marker.size_mm / 2
    top = body.top_pose()
    local = np.array([[-s, s, 0], [s, s, 0], [s, -s, 0], [-s, -s, 0]])
    points = local @ top[:3, :3].T + top[:3, 3]
    return camera.renderer.project(camera.pose(), points), points


def test_eye_in_hand_markers_are_found_where_they_project(rig):
    clock, world, emu, camera = rig(C270)
    frame = camera.read()
    assert frame.image.shape == (480, 640, 3) and frame.image.dtype == np.uint8
    assert np.allclose(frame.camera_matrix[0], [810.06, 0, 325.40])
    found = detect(frame.image)
    assert set(found) == {0, 2}
    for marker_id, name in ((0, "ducky"), (2, "trash")):
        expected, points = truth_corners(world, camera, name)
        err = np.abs(found[marker_id] - expected).max()
        assert err < 1.0, f"{name}: corners {err:.2f} px from where the lens puts them"
        s = world.bodies[name].marker.size_mm / 2
        obj = np.array([[-s, s, 0], [s, s, 0], [s, -s, 0], [-s, -s, 0]], dtype=np.float32)
        ok, _, tvec = cv2.solvePnP(
            obj,
            found[marker_id].astype(np.float32),
            frame.camera_matrix,
            frame.distortion,
            flags=cv2.SOLVEPNP_IPPE_SQUARE,
        )
        cam = camera.pose()
        centre = np.linalg.inv(cam) @ np.append(points.mean(axis=0), 1.0)
        # Durovic 2017: the distance along the view is the weak axis of a marker pose.
        assert ok and np.linalg.norm(tvec.ravel() - centre[:3]) < 0.01 * np.linalg.norm(centre[:3])


def test_frames_follow_the_run_clock(rig):
    clock, world, emu, camera = rig(C270)
    first = camera.read()
    assert first.timestamp == 0.0 and first.index == 0
    assert camera.read() is None, "no new frame until the clock moves on"
    clock.advance(0.01)
    assert camera.read() is None
    clock.advance(0.03)
    frame = camera.read()
    assert frame.index == 1 and frame.timestamp == pytest.approx(1 / 30)
    clock.advance(1.0)
    assert camera.read().index == 31, "the newest frame, not a backlog"


def test_same_seed_same_frames_other_seed_other_noise(rig):
    images = []
    for seed in (5, 5, 6):
        clock, world, emu, camera = rig(C270, seed=seed)
        clock.advance(0.2)
        images.append(camera.read().image)
    assert np.array_equal(images[0], images[1])
    assert not np.array_equal(images[0], images[2])
    assert np.abs(images[0].astype(int) - images[2]).mean() < 6, "only the noise differs"


def test_dropped_frames_at_the_configured_rate_and_reproducibly(rig):
    config = dict(C270, drop_rate=0.3, noise=0.0)
    runs = []
    for _ in range(2):
        clock, world, emu, camera = rig(config, seed=2)
        got = []
        for _ in range(150):
            got.append(camera.read() is not None)
            clock.advance(1 / 30)
        runs.append(got)
    assert runs[0] == runs[1]
    assert 0.18 < 1 - np.mean(runs[0]) < 0.42


def sharpness(image):
    return cv2.Laplacian(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), cv2.CV_64F).var()


def test_moving_camera_blurs_the_image(rig):
    config = dict(C270, noise=0.0, blur=0.0)
    clock, world, emu, camera = rig(config)
    still = camera.read().image
    clock.advance(1 / 30)
    still_again = camera.read().image
    emu.put([205, 25, 130])  # 20 mm sideways in one frame: 0.6 m/s
    world.step(clock.now())
    clock.advance(1 / 30)
    moving = camera.read().image
    assert sharpness(still_again) == pytest.approx(sharpness(still))
    assert sharpness(moving) < 0.7 * sharpness(still)


def test_a_camera_that_moved_and_stopped_before_its_next_frame_is_not_blurred(rig):
    # Frames may be read seconds apart (a look reads none while the arm settles): the
    # blur of the camera's motion is from where it was a tick ago, not at the last frame.
    config = dict(C270, noise=0.0, blur=0.0)
    clock, world, emu, camera = rig(config)
    camera.read()
    emu.put([205, 45, 130])  # 60 mm away, then still for the second before the next frame
    for _ in range(20):
        clock.advance(0.05)
        world.step(clock.now())
    first = camera.read().image
    clock.advance(1 / 30)
    world.step(clock.now())
    second = camera.read().image
    assert sharpness(first) == pytest.approx(sharpness(second), rel=1e-6)


def test_eye_to_hand_arm_link_hides_a_marker(rig):
    clock, world, emu, camera = rig(STAND, tool=(300, -150, 150))
    assert set(detect(camera.read().image)) == {0, 2}
    # The tool box (24 x 24 x 40 mm) right above the ducky's marker hides it from the stand.
    duck = world.bodies["ducky"]
    emu.put([duck.pose[0, 3], duck.pose[1, 3], duck.top + 5])
    world.step(clock.now())
    clock.advance(0.1)
    assert set(detect(camera.read().image)) == {2}


def test_what_did_not_move_is_painted_from_memory_as_drawn_anew(rig):
    """The objects and shadows that did not move are painted from the last frame's strokes
    and outlines; the frame is the one a renderer drawing everything anew gives."""
    clock, world, emu, camera = rig(STAND, tool=(300, -150, 150))
    camera.read()
    before = world_drawables(world)
    emu.put([250, -60, 90])  # the arm moves; the objects on the table do not
    world.step(clock.now())
    clock.advance(0.1)
    frame = camera.read()
    r = camera.renderer
    fresh = Renderer(r.camera, r.table, r.light, r.seed, r.noise, r.blur, r.exposure, r.shadows)
    anew = fresh.render(camera.pose(), world_drawables(world), frame.index)
    assert np.array_equal(frame.image, anew)
    assert not np.array_equal(anew, fresh.render(camera.pose(), before, frame.index))


def test_table_edge_shadow_and_light_are_rendered(rig):
    clock, world, emu, camera = rig(dict(STAND, noise=0.0, blur=0.0), tool=(150, 0, 200))
    image = camera.read().image.astype(int)
    plain = dict(STAND, noise=0.0, blur=0.0, shadows=False)
    _, _, _, camera2 = rig(plain, tool=(150, 0, 200))
    unshadowed = camera2.read().image.astype(int)
    darker = (unshadowed.sum(axis=2) - image.sum(axis=2)) > 30
    assert darker.sum() > 200, "the arm and the objects cast shadows on the table"
    assert (image.sum(axis=2) > unshadowed.sum(axis=2) + 3).sum() == 0


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"mount": "on_the_wall"}, "camera.mount"),
        ({"fps": 0}, "camera.fps"),
        ({"drop_rate": 1.5}, "camera.drop_rate"),
        ({"mount": "eye_to_hand", "position": [0, 0, 100], "look_at": [0, 0, 100]}, "coincide"),
    ],
)
def test_bad_camera_config(change, message, rig):
    with pytest.raises(ConfigError, match=message):
        rig(dict(C270, **change))


def test_hamming_marker_read_by_the_hamming_tracker(rig, camera_profile):
    profile = camera_profile
    profile["tracker"] = {"type": "hamming"}
    profile["tags"] = {
        "ducky": {"id": 1234567, "size_mm": 25},
        "trash": {"ids": [70026], "size_mm": 25},
    }
    clock, world, emu, camera = rig(dict(C270), profile=profile)
    frame = camera.read()
    found = {d.id for d in HammingTracker().detect(frame)}
    assert {1234567, 70026} <= found
