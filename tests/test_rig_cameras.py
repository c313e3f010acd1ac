"""Every camera type started by the rig builder delivers frames and leaves nothing open.

A rig is built from a profile naming each camera type (an OpenCV capture of an
MJPEG stream over HTTP, as from an IP camera or ``armtree serve-sim``; video and
image-folder replay; the simulated camera); frames must arrive, and after the rig closes no thread and no
file descriptor it opened may remain. Cameras that cannot open, or stop
delivering, are HardwareFaults naming the device.
"""

import os
import threading
import time

import cv2
import numpy as np
import pytest

from armtree.api.clock import VirtualClock, WallClock
from armtree.errors import HardwareFault
from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.loader.profile import load_profile
from armtree.plugins.sim.mjpeg import MjpegServer
from armtree.runtime.rig_builder import build_rig


def open_fds() -> set[str]:
    return set(os.listdir("/proc/self/fd"))


class Publisher:
    """Publishes a changing test image to an MJPEG server at ``fps`` until stopped."""

    def __init__(self, server: MjpegServer, fps: float = 30.0) -> None:
        self.server, self.period = server, 1.0 / fps
        self.running = threading.Event()
        self.running.set()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        i = 0
        while self.running.is_set():
            self.server.publish(np.full((120, 160, 3), (i * 7) % 256, np.uint8))
            i += 1
            time.sleep(self.period)

    def stop(self) -> None:
        self.running.clear()
        self.thread.join()


@pytest.fixture
def stream():
    server = MjpegServer()
    server.start()
    publisher = Publisher(server)
    yield server, publisher
    publisher.stop()
    server.close()


@pytest.fixture
def media(tmp_path):
    video = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 20, (64, 48))
    for i in range(20):
        writer.write(np.full((48, 64, 3), 10 * i, np.uint8))
    writer.release()
    folder = tmp_path / "frames"
    folder.mkdir()
    for i in range(3):
        cv2.imwrite(str(folder / f"f{i}.png"), np.full((48, 64, 3), 60 * i, np.uint8))
    return video, folder


def sim_profile():
    """sim_dobot with its camera alone (the world it renders comes with it)."""
    profile = load_profile("sim_dobot")
    data = {k: v for k, v in profile.data.items() if k not in ("arm", "planner", "tracker")}
    return data


def camera_profile(kind, media, stream):
    video, folder = media
    if kind == "sim":
        return sim_profile()
    camera = {
        "opencv-mjpeg": {"type": "opencv", "device": stream[0].url if stream else ""},
        "video": {"type": "video", "path": str(video)},
        "images": {"type": "images", "path": str(folder), "fps": 10},
    }[kind]
    return {"profile": "camera-only", "camera": camera}


def frames_arrive(rig, clock, count=3, seconds=5.0):
    got = []
    deadline = time.monotonic() + seconds
    while len(got) < count and time.monotonic() < deadline:
        frame = rig.camera.read()
        if frame is not None:
            got.append(frame)
        if isinstance(clock, VirtualClock):
            clock.advance(0.1)
        elif frame is None:
            time.sleep(0.005)
    return got


@pytest.mark.parametrize("kind", ["opencv-mjpeg", "video", "images", "sim"])
def test_each_camera_type_starts_delivers_and_closes(kind, media, request):
    stream = request.getfixturevalue("stream") if kind == "opencv-mjpeg" else None
    profile = camera_profile(kind, media, stream)
    clock = WallClock() if kind.startswith("opencv") else VirtualClock()
    manager = get_plugin_manager()
    # Once first, so libraries OpenCV loads on first use are not counted as leaks.
    build_rig(profile, manager, clock).close()
    threads, fds = set(threading.enumerate()), open_fds()
    rig = build_rig(profile, manager, clock)
    assert rig.started == ["camera"]
    frames = frames_arrive(rig, clock)
    assert len(frames) == 3, f"{kind}: only {len(frames)} frames arrived"
    assert all(f.image.ndim == 3 and f.image.size > 0 for f in frames)
    assert len({f.index for f in frames}) == 3, "three different frames"
    rig.close()
    # The stream's server notices the client has gone at its next write (within 0.5 s on a
    # quiet machine); the wait ends as soon as the threads do, so its bound can be generous.
    deadline = time.monotonic() + 20.0
    while leftover := [t.name for t in set(threading.enumerate()) - threads if t.is_alive()]:
        if time.monotonic() > deadline:
            break
        time.sleep(0.05)
    assert leftover == [], f"{kind}: threads left running: {leftover}"
    assert open_fds() - fds == set(), f"{kind}: file descriptors left open"


def test_a_camera_index_that_does_not_exist_is_a_fault_naming_it():
    profile = {"camera": {"type": "opencv", "device": 57}}
    threads = set(threading.enumerate())
    with pytest.raises(HardwareFault, match="camera index 57") as info:
        build_rig(profile, get_plugin_manager(), WallClock())
    assert info.value.device == "57"
    assert [t for t in set(threading.enumerate()) - threads if t.is_alive()] == []


def test_a_stream_url_nobody_serves_is_a_fault_naming_it():
    server = MjpegServer()
    url = server.url  # bound but never started: connections are refused or hang up
    server.close()
    profile = {"camera": {"type": "opencv", "device": url, "open_timeout_s": 2.0}}
    with pytest.raises(HardwareFault, match="stream") as info:
        build_rig(profile, get_plugin_manager(), WallClock())
    assert info.value.device == url


def test_a_stream_that_stops_mid_run_is_a_fault_and_interrupts_the_run(stream):
    server, publisher = stream
    interrupts = []
    profile = {"camera": {"type": "opencv", "device": server.url, "stall_timeout_s": 0.5}}
    rig = build_rig(
        profile, get_plugin_manager(), WallClock(), interrupt=lambda r, f=None: interrupts.append(f)
    )
    try:
        assert frames_arrive(rig, rig.clock, count=2)
        publisher.stop()
        deadline = time.monotonic() + 5.0
        while not interrupts and time.monotonic() < deadline:
            time.sleep(0.02)
        assert interrupts and isinstance(interrupts[0], HardwareFault)
        assert interrupts[0].device == server.url and "frame" in interrupts[0].message
        with pytest.raises(HardwareFault, match=server.url):
            rig.camera.read()
    finally:
        rig.close()
