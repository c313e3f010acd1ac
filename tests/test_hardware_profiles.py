"""The shipped real-hardware profiles: valid, pointing at real devices, ready to measure.

Each validates with every shipped tree (as ``armtree check`` does), names a serial
port and baud rate and a USB camera, and marks what a user must measure. Those
with a simulated twin carry the twin's geometry (places, tags, workcell, camera
intrinsics and pose), so ``serve-sim`` of the twin stands in for the bench.
"""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import armtree
from armtree.config.resolve import available
from armtree.plugins.sim.camera import camera_extrinsics

REAL = ("dobot_v1", "dobot_v1_opendobot", "dobot_magician", "vicra", "dh_ssc32", "so101", "koch")
TWINS = {
    "dobot_v1": "sim_dobot",
    "dobot_v1_opendobot": "sim_dobot",
    "dobot_magician": "sim_magician",
    "vicra": "sim_vicra",
    "dh_ssc32": "sim_dh",
    "so101": "sim_so101",
    "koch": "sim_koch",
}
TREES = ("load_ducky", "clean_up", "pick_and_place", "touch_tag", "track")


@pytest.mark.parametrize("name", REAL)
def test_a_real_profile_names_its_devices_and_what_to_measure(name):
    profile = armtree.load_profile(name)
    arm, camera = profile.component("arm"), profile.component("camera")
    assert arm["port"].startswith("/dev/tty") and arm["baud"] > 0
    assert camera["type"] == "opencv" and camera["device"] == 0
    assert profile.section("workcell"), "the task geometry the skills read"
    text = Path(profile.source).read_text()
    assert text.count("MEASURE") >= 4 and "(mm)" in text and "(px)" in text


@pytest.mark.parametrize("name", REAL)
def test_every_shipped_tree_validates_on_a_real_profile(name):
    for tree in TREES:
        loaded = armtree.load_tree(f"{tree}.yaml", rig=f"{name}.yaml")
        assert loaded.profile.name == name


@pytest.mark.parametrize(("real", "sim"), sorted(TWINS.items()))
def test_a_real_profile_has_its_simulated_twins_geometry(real, sim):
    r, s = armtree.load_profile(real), armtree.load_profile(sim)
    fix = f"{sim} changed: copy the change into hardware/{real}.yaml"
    for section in ("places", "tags", "workcell"):
        assert r.data[section] == s.data[section], f"{section}: {fix}"
    rc, sc = r.component("camera"), s.component("camera")
    assert (rc["mount"], rc["intrinsics"], rc["distortion"]) == (
        sc["mount"],
        sc["intrinsics"],
        sc["distortion"],
    )
    np.testing.assert_allclose(rc["extrinsics"], camera_extrinsics(dict(sc)), atol=1e-9)
    link = ("port", "connect_timeout", "firmware", "baud", "board")  # the link, not geometry
    arm_r = {k: v for k, v in r.component("arm").items() if k not in link}
    assert arm_r == {k: v for k, v in s.component("arm").items() if k not in link}, f"arm: {fix}"


def test_the_profiles_ship_and_armtree_check_accepts_them(tmp_path):
    assert set(REAL) <= set(available("profile"))
    exe = Path(sys.executable).parent / "armtree"
    if not exe.exists():
        pytest.skip("the armtree console script is not installed in this environment")
    done = subprocess.run(
        [str(exe), "check", "load_ducky.yaml", "--rig", "dobot_magician.yaml"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "on dobot_magician" in done.stdout
