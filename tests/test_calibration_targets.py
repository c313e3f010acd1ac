"""Where calibrations and experiments put things: targets clear of what is on the table,
validation poses the arm reaches without touching anything."""

from types import SimpleNamespace

import numpy as np
import py_trees
from py_trees.common import Status
from test_skills_fakes import Marker, _clean_blackboard, make_rig, run  # noqa: F401

from armtree.config.params import Binding
from armtree.maths.motion.scene import Scene
from armtree.plugins.calibration.occupied import declared_keep_outs, free
from armtree.plugins.calibration.trials import PlaceTarget, PlanTargets


def test_targets_keep_clear_of_the_markers_the_camera_sees():
    trash = [Marker(2, np.array([220.0, 40.0, 20.0])), Marker(3, np.array([180.0, -60.0, 20.0]))]
    nearest = {}
    for keep_out in (0.0, 80.0):
        rig = make_rig(trash, mount="eye_to_hand")
        rig.step(0.0)
        node = PlanTargets("plan", count=20, keep_out_mm=keep_out, targets=Binding("t"))
        status, _ = run(node, rig)
        assert status is Status.SUCCESS, node.feedback_message
        targets = np.array(node.bb.get("t"))
        assert len(targets) == 20
        nearest[keep_out] = min(
            np.linalg.norm(targets[:, :2] - m.position[:2], axis=1).min() for m in trash
        )
    assert nearest[0.0] < 80.0 <= nearest[80.0]  # without the overview some land on the trash


def test_the_profiles_obstacles_are_kept_out_of_below_their_top():
    scene = Scene.from_profile(
        {
            "obstacles": [
                {"box": {"name": "crate", "center": [-200, -350, 50], "size": [80, 80, 100]}}
            ]
        }
    )
    (crate,) = declared_keep_outs(scene)
    assert crate.name == "crate" and np.isclose(crate.top_z, 100.0)
    points = np.array([[-200, -350, 0], [-170, -320, 50], [-200, -350, 130], [-80, -350, 0]], float)
    assert free(points, [crate], clearance=20.0).tolist() == [False, False, True, True]


def test_a_target_found_occupied_when_placed_goes_to_a_clear_spare():
    # a Duckybot parked on the first target after the targets were drawn
    placed = []

    def place(marker_id, xy):
        placed.append((marker_id, np.asarray(xy, dtype=float)))
        return SimpleNamespace(done=True, error=None, value=np.append(xy, 0.0))

    rig = make_rig([Marker(1, np.array([230.0, 40.0, 40.0]))], mount="eye_to_hand")
    rig.reference = SimpleNamespace(place_marker=place)
    rig.tags["target"] = SimpleNamespace(ids=(9,))
    rig.step(0.0)
    bb = py_trees.blackboard.Client(name="plan")
    for key in ("t", "s", "i"):
        bb.register_key(key=key, access=py_trees.common.Access.WRITE)
    bb.t = [[240.0, 50.0, 0.0], [100.0, -80.0, 0.0]]
    bb.s = [[250.0, 60.0, 0.0], [150.0, -120.0, 0.0]]  # the first spare is under it too
    bb.i = 0
    node = PlaceTarget("place", targets=Binding("t"), spares=Binding("s"), index=Binding("i"))
    status, _ = run(node, rig)
    assert status is Status.SUCCESS, node.feedback_message
    assert len(placed) == 1 and placed[0][0] == 9
    assert np.allclose(placed[0][1], [150.0, -120.0])
    assert bb.t[0] == [150.0, -120.0, 0.0] and bb.s == [[250.0, 60.0, 0.0]]
    assert "under duckybot marker 1" in node.feedback_message
