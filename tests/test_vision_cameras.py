"""Cameras: image-folder and video replay, the OpenCV device camera, intrinsics from profiles."""

import threading

import cv2
import numpy as np
import pytest

from armtree.api.clock import VirtualClock
from armtree.api.imaging import Intrinsics, IntrinsicsBySize, load_calibration, save_calibration
from armtree.api.rig import RigContext
from armtree.errors import ConfigError, HardwareFault
from armtree.plugins.cameras.opencv_camera import OpenCVCamera, opencv_factory
from armtree.plugins.cameras.replay import images_factory, video_factory

C270 = {"fx": 810.06, "fy": 810.76, "cx": 325.40, "cy": 249.02}
C270_DIST = [0.01584, 0.37926, -0.00056, 0.00331, 0.0]


@pytest.fixture
def folder(tmp_path):
    for i in range(3):
        cv2.imwrite(str(tmp_path / f"f{i:02d}.png"), np.full((48, 64, 3), 50 * i, np.uint8))
    return tmp_path


def ctx(clock=None, profile=None):
    return RigContext(profile=profile, clock=clock or VirtualClock())


def test_images_follow_the_run_clock(folder):
    clock = VirtualClock()
    cam = images_factory(
        {
            "type": "images",
            "path": str(folder),
            "fps": 10,
            "intrinsics": C270,
            "distortion": C270_DIST,
        },
        ctx(clock),
    )
    assert cam.read() is None, "nothing before start()"
    cam.start()
    first = cam.read()
    assert first.image[0, 0, 0] == 0 and first.timestamp == 0.0
    assert np.allclose(first.camera_matrix, [[810.06, 0, 325.40], [0, 810.76, 249.02], [0, 0, 1]])
    assert np.allclose(first.distortion, C270_DIST)
    assert cam.read() is None, "no new frame until the clock moves"
    clock.advance(0.25)
    second = cam.read()
    assert second.image[0, 0, 0] == 100 and second.timestamp == pytest.approx(0.2)
    clock.advance(1.0)
    assert cam.read() is None and cam.finished


def test_images_each_and_loop(folder):
    cam = images_factory({"path": str(folder), "pace": "each", "loop": True}, ctx())
    cam.start()
    levels = [cam.read().image[0, 0, 0] for _ in range(5)]
    assert levels == [0, 50, 100, 0, 50]
    assert [f.index for f in images_factory({"path": str(folder)}, ctx()).frames()] == [0, 1, 2]


def test_frames_without_intrinsics_carry_a_nominal_matrix(folder):
    cam = images_factory({"path": str(folder / "*.png")}, ctx())
    frame = next(cam.frames())
    assert frame.camera_matrix[0, 0] == 64 and cam.intrinsics.get(64, 48).calibrated is False


def test_image_folder_errors(tmp_path):
    with pytest.raises(ConfigError, match="no images"):
        images_factory({"path": str(tmp_path)}, ctx())
    with pytest.raises(ConfigError, match="not a folder"):
        images_factory({"path": str(tmp_path / "missing")}, ctx())
    (tmp_path / "bad.png").write_text("not a png")
    cam = images_factory({"path": str(tmp_path), "pace": "each"}, ctx())
    cam.start()
    with pytest.raises(HardwareFault, match="bad.png"):
        cam.read()
    with pytest.raises(ConfigError, match="fps"):
        images_factory({"path": str(tmp_path), "fps": 0}, ctx())


@pytest.fixture
def video(tmp_path):
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 20, (64, 48))
    for i in range(10):
        writer.write(np.full((48, 64, 3), 20 * i, np.uint8))
    writer.release()
    return path


def test_video_replay_paced_by_clock(video):
    clock = VirtualClock()
    cam = video_factory({"path": str(video)}, ctx(clock))
    assert cam.fps == 20.0, "the file's own rate"
    cam.start()
    assert abs(int(cam.read().image[0, 0, 0]) - 0) < 8
    clock.advance(0.25)  # frame 5 is due; 1-4 are skipped
    frame = cam.read()
    assert abs(int(frame.image[0, 0, 0]) - 100) < 8 and frame.timestamp == pytest.approx(0.25)
    clock.advance(10)
    assert cam.read() is None and cam.finished
    assert len(list(cam.frames())) == 10
    cam.close()


def test_video_errors(tmp_path):
    with pytest.raises(ConfigError, match="no video file"):
        video_factory({"path": str(tmp_path / "none.avi")}, ctx())
    junk = tmp_path / "junk.avi"
    junk.write_bytes(b"\0" * 100)
    cam = video_factory({"path": str(junk), "fps": 10}, ctx())
    with pytest.raises(ConfigError, match="junk.avi"):
        cam.start()


def test_calibration_file_round_trip_and_profile_reference(tmp_path, folder):
    k = np.array([[800.0, 0, 319.5], [0, 802.0, 239.5], [0, 0, 1]])
    save_calibration(
        tmp_path / "cam.yaml", Intrinsics(k, np.array(C270_DIST), 640, 480), rms_px=0.2
    )
    loaded = load_calibration(tmp_path / "cam.yaml")
    assert np.allclose(loaded.camera_matrix, k) and loaded.extra["rms_px"] == 0.2

    class Profile:
        source = tmp_path / "rig.yaml"
        data = {}

    cam = images_factory({"path": str(folder), "calibration": "cam.yaml"}, ctx(profile=Profile()))
    frame = next(cam.frames())  # 64x48 frames: intrinsics scaled from 640x480
    assert frame.camera_matrix[0, 0] == pytest.approx(80.0)
    assert frame.camera_matrix[0, 2] == pytest.approx(31.5)


@pytest.mark.parametrize(
    ("config", "message"),
    [
        ({"intrinsics": {"fx": 800, "fy": 800, "cx": 320}}, "missing cy"),
        ({"intrinsics": {"fx": -1, "fy": 800, "cx": 320, "cy": 240}}, "positive"),
        ({"intrinsics": C270, "distortion": [1, 2, 3]}, "4, 5, 8"),
        ({"calibration": "nowhere.yaml"}, "no file"),
        ({"extrinsics": [[1, 0], [0, 1]]}, "4x4"),
        ({"mount": "on_the_wall"}, "mount"),
    ],
)
def test_intrinsics_config_errors(folder, config, message):
    with pytest.raises(ConfigError, match=message):
        images_factory({"path": str(folder), **config}, ctx())


def test_bad_calibration_files(tmp_path):
    (tmp_path / "a.yaml").write_text("intrinsics: [1, 2\n")
    with pytest.raises(ConfigError) as err:
        load_calibration(tmp_path / "a.yaml")
    assert err.value.file.endswith("a.yaml") and err.value.line is not None
    (tmp_path / "b.yaml").write_text("width: 640\n")
    with pytest.raises(ConfigError, match="intrinsics"):
        load_calibration(tmp_path / "b.yaml")


def test_opencv_camera_missing_device_is_a_hardware_fault():
    faults = []
    context = RigContext(
        profile=None, clock=VirtualClock(), interrupt=lambda r, f=None: faults.append(f)
    )
    cam = opencv_factory({"type": "opencv", "device": "/dev/no-such-video9"}, context)
    with pytest.raises(HardwareFault) as err:
        cam.start()
    assert err.value.device == "/dev/no-such-video9"
    assert faults and faults[0] is err.value
    cam.close()


def test_opencv_camera_streams_a_file_then_reports_the_end(video):
    ended = threading.Event()
    context = RigContext(
        profile=None, clock=VirtualClock(), interrupt=lambda r, f=None: ended.set()
    )
    cam = opencv_factory(
        {"device": str(video), "intrinsics": C270, "stall_timeout_s": 0.3, "fps": 20}, context
    )
    cam.start()
    assert cam.wait_frame(5.0)
    frame = cam.read()
    assert frame is not None and frame.image.shape == (48, 64, 3)
    assert frame.camera_matrix[0, 0] == pytest.approx(810.06 * 64 / 64)
    assert ended.wait(5.0), "a stream that stops delivering is reported"
    with pytest.raises(HardwareFault, match="stopped delivering"):
        cam.read()
    cam.close()
    cam.close()


class BlockingCapture:
    """A capture whose read() never returns, like a USB camera that hangs."""

    def __init__(self, device, opened=True, block_open=False):
        self.release_event = threading.Event()
        if block_open:
            self.release_event.wait(10)
        self.opened = opened

    def isOpened(self):  # noqa: N802 - OpenCV's name
        return self.opened

    def set(self, *_):
        return True

    def read(self):
        self.release_event.wait(10)
        return False, None

    def release(self):
        self.release_event.set()


def test_a_stalled_stream_is_a_fault_not_a_hang():
    now = [0.0]
    captures = []

    def factory(device):
        captures.append(BlockingCapture(device))
        return captures[-1]

    cam = OpenCVCamera(
        1, VirtualClock(), IntrinsicsBySize(None), stall_timeout_s=2.0,
        capture_factory=factory, wall=lambda: now[0],
    )  # fmt: skip
    cam.start()
    assert cam.read() is None
    now[0] = 2.5
    with pytest.raises(HardwareFault, match="stalled") as err:
        cam.read()
    assert err.value.device == "1"
    captures[0].release()
    cam.close()


def test_a_device_that_never_opens_times_out():
    cam = OpenCVCamera(
        2, VirtualClock(), IntrinsicsBySize(None), open_timeout_s=0.2,
        capture_factory=lambda d: BlockingCapture(d, block_open=True),
    )  # fmt: skip
    with pytest.raises(HardwareFault, match="did not open within 0.2 s"):
        cam.start()
