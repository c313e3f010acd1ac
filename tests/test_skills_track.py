"""track on fake rigs (Showers 2016, appendices C and D)."""

import numpy as np
from py_trees.common import Access, Status
from test_skills_fakes import TOOL_T_CAMERA, Marker, _clean_blackboard, make_rig, run  # noqa: F401

from armtree.config.params import Binding
from armtree.plugins.skills.track import Track


def moving_bot():
    return Marker(1, np.array([200.0, 0.0, 0.0]), velocity=np.array([0.0, 15.0, 0.0]), stop_at=3.0)


def camera_xy(rig):
    return (rig.arm.actual_pose() @ TOOL_T_CAMERA)[:2, 3]


def test_track_follows_a_moving_marker_until_it_stands_still():
    bot = moving_bot()
    rig = make_rig([bot])
    rig.arm.q = np.array([-6.0, 200.0, 100.0])  # camera roughly over the bot
    node = Track("track", tag="duckybot", pose=Binding("bot"), still_s=2.5)
    status, ticks = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert np.allclose(bot.position, [200, 45, 0], atol=1.0)
    assert ticks * 0.05 >= 3.0 + 2.5  # not before it stopped and stood still
    assert np.linalg.norm(camera_xy(rig) - bot.position[:2]) < 15.0  # the camera is above it
    assert np.linalg.norm(np.array(node.bb.get("bot")) - bot.position) < 15.0


def test_track_fails_once_the_marker_is_lost_for_its_frames():
    rig = make_rig([Marker(1, np.array([200.0, 0.0, 0.0]))])
    rig.arm.q = np.array([-6.0, 200.0, 100.0])
    rig.tracker.blind_frames = 1000
    node = Track("track", tag="duckybot", lost_frames=10, settle_s=0.0)
    status, ticks = run(node, rig)
    assert (
        status is Status.FAILURE
        and "lost the 'duckybot' tag for 10 frames" in node.feedback_message
    )
    assert ticks <= 12


def test_track_rides_out_short_dropouts():
    rig = make_rig([Marker(1, np.array([200.0, 0.0, 0.0]))])
    rig.arm.q = np.array([-6.0, 200.0, 100.0])
    rig.tracker.blind_frames = 20
    node = Track("track", tag="duckybot", still_s=0.5)
    status, _ = run(node, rig)
    assert status is Status.SUCCESS


def test_track_ends_when_its_until_key_becomes_true():
    rig = make_rig([moving_bot()])
    rig.arm.q = np.array([-6.0, 200.0, 100.0])
    node = Track("track", tag="duckybot", still_s=0.0, until=Binding("done"))
    node.bb.register_key("done", access=Access.WRITE)
    node.bb.set("done", False)
    node.setup(rig=rig, clock=rig.clock)
    for _ in range(20):
        node.tick_once()
        rig.clock.advance(0.05)
        rig.step(rig.clock.now())
    assert node.status is Status.RUNNING
    node.bb.set("done", True)
    status, _ = run(node, rig, max_ticks=10)
    assert status is Status.SUCCESS


def test_track_goes_back_when_following_hides_the_marker():
    rig = make_rig([Marker(1, np.array([200.0, 0.0, 0.0]))])
    rig.arm.q = np.array([-6.0, 200.0, 120.0])  # camera 150 mm up: the marker is in view
    rig.tracker.blind_below_z = 140.0  # following to 5 tag sizes (125 mm) hides it
    node = Track("track", tag="duckybot", still_s=2.0, lost_frames=10)
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert (rig.arm.actual_pose() @ TOOL_T_CAMERA)[2, 3] >= 140.0


def test_with_a_fixed_camera_the_arm_stays_put_while_the_marker_moves():
    # eye-to-hand: following would only put the tool between the camera and the marker
    bot = moving_bot()
    rig = make_rig([bot], mount="eye_to_hand")
    start = rig.arm.actual_pose()[:3, 3].copy()
    node = Track("track", tag="duckybot", pose=Binding("bot"), still_s=2.0)
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    np.testing.assert_allclose(rig.arm.actual_pose()[:3, 3], start, atol=1e-9)
    assert np.linalg.norm(np.array(node.bb.get("bot")) - bot.position) < 15.0
