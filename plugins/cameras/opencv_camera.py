"""The ``opencv`` camera: a USB camera (or any stream) through ``cv2.VideoCapture``.

Capture runs on its own thread, which keeps only the newest image, so
:meth:`read` never waits on the device. Opening is also done on that thread
with a deadline: a device that does not open, or stops delivering frames for
``stall_timeout_s``, is a :class:`HardwareFault` naming it (raised by
``start()`` or ``read()``, and passed to the run's interrupt), never a hang.
Stall times are wall-clock seconds (the device's time); frames are stamped
with the run's clock. The backend's own open and read timeouts are bounded by
the same figures, so a stream that stops lets the capture thread end rather
than block inside OpenCV, and :meth:`OpenCVCamera.close` leaves no thread behind.
OpenCV's and FFmpeg's console warnings are silenced: the fault says what failed.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol, cast

import cv2
import numpy as np

from armtree.api.component_factory import ComponentFactory
from armtree.api.imaging import INTRINSICS_PARAMS, IntrinsicsBySize
from armtree.api.rig import Frame, RigContext
from armtree.config.component_config import config_error
from armtree.config.params import Param
from armtree.errors import HardwareFault

from .base import FrameSourceCamera, camera_config

# Read by OpenCV when FFmpeg is first used; -8 is FFmpeg's "quiet".
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
# Errors only: the V4L2 and FFmpeg open warnings repeat what the fault says.
cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)


def open_capture(device: int | str, open_timeout_s: float, read_timeout_s: float) -> Any:
    """``cv2.VideoCapture(device)`` with the backend's open and read timeouts bounded (seconds)."""
    params = [
        cv2.CAP_PROP_OPEN_TIMEOUT_MSEC,
        max(1, int(open_timeout_s * 1000)),
        cv2.CAP_PROP_READ_TIMEOUT_MSEC,
        max(1, int(read_timeout_s * 1000)),
    ]
    return cv2.VideoCapture(device, cv2.CAP_ANY, params)


class OpenCVCamera(FrameSourceCamera):
    """A ``cv2.VideoCapture`` device by index (``0``) or path (``/dev/video0``, a URL)."""

    def __init__(
        self,
        device: int | str,
        clock: Any,
        intrinsics: IntrinsicsBySize,
        *,
        width: int | None = 640,
        height: int | None = 480,
        fps: float | None = 30.0,
        open_timeout_s: float = 5.0,
        stall_timeout_s: float = 2.0,
        mount: str = "eye_to_hand",
        extrinsics: np.ndarray | None = None,
        interrupt: Callable[[str, HardwareFault | None], None] | None = None,
        capture_factory: Callable[[int | str], Any] | None = None,
        wall: Callable[[], float] = time.monotonic,
    ) -> None:
        super().__init__(f"camera {device}", clock, intrinsics, mount, extrinsics)
        self.device = device
        self.width, self.height, self.fps = width, height, fps
        self.open_timeout_s = float(open_timeout_s)
        self.stall_timeout_s = float(stall_timeout_s)
        self._interrupt = interrupt
        self._capture_factory = capture_factory
        self._wall = wall
        self._lock = threading.Condition()
        self._opened = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._capture: Any = None
        self._newest: tuple[np.ndarray, float] | None = None
        self._newest_seq = 0
        self._returned_seq = 0
        self._last_frame_wall = 0.0
        self._fault: HardwareFault | None = None

    @property
    def fault(self) -> HardwareFault | None:
        """The fault that stopped the camera, if any."""
        return self._fault

    def start(self) -> None:
        """Open the device on the capture thread; HardwareFault if it does not open in time."""
        if self._thread is not None:
            return
        self._thread = threading.Thread(target=self._run, name=f"armtree-{self.name}", daemon=True)
        self._thread.start()
        if not self._opened.wait(self.open_timeout_s):
            self._stop.set()
            self._fail(f"did not open within {self.open_timeout_s:g} s")
        if self._fault is not None:
            raise self._fault

    def read(self) -> Frame | None:
        """The newest frame if one arrived since the last call, else None; raises the camera's fault."""
        if self._fault is not None:
            raise self._fault
        with self._lock:
            fresh = self._newest_seq > self._returned_seq
            newest = self._newest
            self._returned_seq = self._newest_seq
            last = self._last_frame_wall
        if fresh and newest is not None:
            return self.make_frame(newest[0], newest[1])
        if self._opened.is_set() and self._wall() - last > self.stall_timeout_s:
            self._fail(f"no frame for {self.stall_timeout_s:g} s (stream stalled)")
            raise self._fault  # type: ignore[misc]
        return None

    def wait_frame(self, timeout: float) -> bool:
        """Block until a frame newer than the last read one is ready (scripts and tests, not ticks)."""
        with self._lock:
            return self._lock.wait_for(
                lambda: self._newest_seq > self._returned_seq or self._fault is not None, timeout
            )

    def close(self) -> None:
        """Stop the capture thread and release the device; safe to call twice."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=max(1.0, self.stall_timeout_s))
        # A thread stuck inside the driver keeps the device; it is a daemon and ends with us.
        if self._thread is None or not self._thread.is_alive():
            self._release(self._capture)

    def _release(self, cap: Any) -> None:
        with self._lock:
            if cap is None or cap is not self._capture:
                return
            self._capture = None
        cap.release()

    # -- the capture thread --------------------------------------------------

    def _run(self) -> None:
        try:
            if self._capture_factory is None:
                cap = open_capture(self.device, self.open_timeout_s, self.stall_timeout_s)
            else:
                cap = self._capture_factory(self.device)
        except Exception as exc:  # noqa: BLE001 - any backend error means the device is unusable
            self._fail(f"cannot open: {exc}")
            self._opened.set()
            return
        with self._lock:
            self._capture = cap
        if not cap.isOpened():
            self._fail(f"cannot open {_expected(self.device)}")
            self._opened.set()
            return
        if self.width and self.height:
            cap.set(cv2.CAP_PROP_FRAME_WIDTH, self.width)
            cap.set(cv2.CAP_PROP_FRAME_HEIGHT, self.height)
        if self.fps:
            cap.set(cv2.CAP_PROP_FPS, self.fps)
        self._last_frame_wall = self._wall()
        self._opened.set()
        failures_since = None
        while not self._stop.is_set():
            ok, image = cap.read()
            now = self._wall()
            if ok and image is not None:
                failures_since = None
                with self._lock:
                    self._newest = (image, self.clock.now())
                    self._newest_seq += 1
                    self._last_frame_wall = now
                    self._lock.notify_all()
                continue
            failures_since = failures_since or now
            if now - failures_since > self.stall_timeout_s:
                self._fail(f"stopped delivering frames for {self.stall_timeout_s:g} s")
                self._release(cap)
                return
            self._stop.wait(0.01)

    def _fail(self, message: str) -> None:
        if self._fault is not None:
            return
        self._fault = HardwareFault(message, str(self.device))
        with self._lock:
            self._lock.notify_all()
        if self._interrupt is not None:
            self._interrupt(f"camera {self.device}: {message}", self._fault)


def _expected(device: int | str) -> str:
    """What the device was expected to be, for the fault's message."""
    if isinstance(device, int):
        return f"camera index {device} (no such camera, busy, or no permission; /dev/video* lists them)"
    if "://" in device:
        return "the stream (is the server running and the URL right? expected e.g. an MJPEG stream)"
    return "the device or file (no such device, busy, no permission, or not a video)"


class _OpenCVFactory(ComponentFactory[OpenCVCamera], Protocol):
    """:func:`opencv_factory` with its members: ``simulated(config)`` is always False."""

    simulated: Callable[[dict[str, Any]], bool]


def opencv_factory(config: dict[str, Any], context: RigContext) -> OpenCVCamera:
    """A USB camera (index or path) through cv2.VideoCapture, captured on its own thread."""
    values, intr, extrinsics, where = camera_config(config, context, _PARAMS)
    device = values["device"]
    if isinstance(device, bool) or not isinstance(device, (int, str)) or device == "":
        raise config_error(
            where, "camera.device", f"an index (0) or a path (/dev/video0), got {device!r}"
        )
    for key in ("open_timeout_s", "stall_timeout_s", "fps"):
        if values[key] is not None and not values[key] > 0:
            raise config_error(where, f"camera.{key}", f"must be positive, got {values[key]}")
    return OpenCVCamera(
        device,
        context.clock,
        intr,
        width=values["width"],
        height=values["height"],
        fps=values["fps"],
        open_timeout_s=values["open_timeout_s"],
        stall_timeout_s=values["stall_timeout_s"],
        mount=values["mount"],
        extrinsics=extrinsics,
        interrupt=context.interrupt,
    )


# mypy types a def as a plain callable, which has no attributes to set: the same function,
# typed as what it is once the members below are set.
opencv_factory = cast(_OpenCVFactory, opencv_factory)
opencv_factory.simulated = lambda config: False  # always a device
# a module constant too: in the factory's body mypy still sees the def, without PARAMS
_PARAMS: tuple[Param, ...] = (
    # a negative index crashed OpenCV's capture thread (a segfault): refused at load
    Param("device", "any", 0, doc="camera index (>= 0) or device path / stream URL", minimum=0),
    Param("width", "int", 640, unit="px", doc="requested image width", minimum=1),
    Param("height", "int", 480, unit="px", doc="requested image height", minimum=1),
    Param("fps", "float", 30.0, unit="Hz", doc="requested frame rate", exclusive_minimum=0),
    Param(
        "open_timeout_s",
        "float",
        5.0,
        unit="s",
        doc="how long opening may take",
        exclusive_minimum=0,
    ),
    Param(
        "stall_timeout_s",
        "float",
        2.0,
        unit="s",
        doc="no frame for this long is a fault",
        exclusive_minimum=0,
    ),
    *INTRINSICS_PARAMS,
)
opencv_factory.PARAMS = _PARAMS
