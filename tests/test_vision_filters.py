"""Pose smoothing per marker id (Showers 2016, appendix D) and tracker preprocessing."""

import subprocess
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from armtree.api.rig import Detection
from armtree.errors import ConfigError
from armtree.maths.perception.filters import PoseFilter
from armtree.plugins.trackers.preprocess import Preprocessing, to_gray


def det(marker_id, t, r=None):
    return Detection(marker_id, np.zeros((4, 2)), tvec=np.array(t, float), rvec=r)


def test_first_measurement_is_taken_as_is_then_alpha_blends():
    f = PoseFilter()
    assert f.alpha == 0.2
    assert np.allclose(f.update(1, [0, 0, 100]).tvec, [0, 0, 100])
    # Showers 2016, appendix D: P_est = 0.2 P + 0.8 P_est
    assert np.allclose(f.update(1, [10, 0, 100]).tvec, [2, 0, 100])
    assert np.allclose(f.update(1, [10, 0, 100]).tvec, [3.6, 0, 100])
    assert f.get(1).samples == 3


def test_a_filter_of_positions_alone_does_not_load_scipy_rotations():
    # SciPy's rotations cost a third of a second to import: the Track skill filters
    # positions only and must not pay for them in the middle of a run.
    code = (
        "import sys\n"
        "from armtree.maths.perception.filters import PoseFilter\n"
        "f = PoseFilter()\n"
        "f.update(1, [0, 0, 100])\n"
        "print(f.update(1, [10, 0, 100]).tvec.tolist(), 'scipy.spatial' in sys.modules)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.stdout.split() == ["[2.0,", "0.0,", "100.0]", "False"], done.stderr


def test_markers_are_filtered_independently_and_reset_when_lost():
    f = PoseFilter(max_missed=1)
    f.update_frame([det(1, [0, 0, 100]), det(2, [50, 0, 100])])
    f.update_frame([det(1, [10, 0, 100])])
    assert 2 in f and f.get(2).missed == 1
    f.update_frame([det(1, [10, 0, 100])])
    assert 2 not in f, "lost for two frames with max_missed=1"
    f.update_frame([det(2, [80, 0, 100])])
    assert np.allclose(f.get(2).tvec, [80, 0, 100]), "a marker that comes back starts afresh"


def test_default_resets_on_the_first_missed_frame_and_ignores_poseless():
    f = PoseFilter()
    f.update_frame([det(1, [0, 0, 100])])
    f.update_frame([Detection(1, np.zeros((4, 2)))])
    marker_id = 1
    assert marker_id not in f


def test_rotations_are_smoothed_on_the_short_way():
    f = PoseFilter(alpha=0.5)
    f.update(1, [0, 0, 0], Rotation.from_euler("z", 170, degrees=True).as_rotvec())
    out = f.update(1, [0, 0, 0], Rotation.from_euler("z", -170, degrees=True).as_rotvec())
    angle = Rotation.from_rotvec(out.rvec).as_euler("xyz", degrees=True)[2]
    assert abs(abs(angle) - 180.0) < 1e-6


@pytest.mark.parametrize(("alpha", "missed"), [(0.0, 0), (1.5, 0), (0.2, -1)])
def test_filter_arguments_are_checked(alpha, missed):
    with pytest.raises(ValueError):
        PoseFilter(alpha, missed)


def test_seed_preprocessing_binarises_at_forty_percent_then_blurs():
    gray = np.tile(np.arange(256, dtype=np.uint8), (8, 1))
    out = Preprocessing(threshold=0.4).apply(gray)
    assert set(np.unique(out)) == {0, 255}
    assert out[0, 102] == 0 and out[0, 103] == 255
    blurred = Preprocessing(threshold=0.4, blur=3).apply(gray)
    assert 0 < blurred[0, 102] < 255 or 0 < blurred[0, 103] < 255


def test_adaptive_threshold_follows_uneven_light():
    ramp = np.tile(np.linspace(40, 250, 200), (50, 1)).astype(np.uint8)
    ramp[20:30, 20:30] -= 30  # dark spot in the dim part
    ramp[20:30, 170:180] -= 30  # dark spot in the bright part
    out = Preprocessing(adaptive=True, block_px=15, offset=5).apply(ramp)
    assert out[25, 25] == 0 and out[25, 175] == 0 and out[25, 100] == 255


def test_preprocess_config_errors():
    with pytest.raises(ConfigError, match="unknown key 'treshold'"):
        Preprocessing.from_config({"treshold": 0.4})
    with pytest.raises(ConfigError, match="block_px"):
        Preprocessing.from_config({"adaptive": True, "block_px": 10})
    with pytest.raises(ConfigError, match="mapping"):
        Preprocessing.from_config([0.4])


def test_to_gray_accepts_grey_bgr_bgra_and_refuses_others():
    assert to_gray(np.zeros((4, 4, 3), np.uint8)).shape == (4, 4)
    assert to_gray(np.zeros((4, 4, 4), np.uint8)).shape == (4, 4)
    with pytest.raises(ValueError):
        to_gray(np.zeros((4, 4, 2), np.uint8))
    with pytest.raises(ValueError):
        to_gray(np.zeros((4, 4), np.uint16))
