"""The ``sim`` camera: frames rendered from the simulated world on the run's clock.

Frames exist at the camera's ``fps`` on the run's clock; :meth:`SimCamera.read`
renders the newest one only when asked (so unread frames cost nothing) and
returns None when no new frame is due or the frame was dropped. Eye-in-hand
cameras ride on the tool (pose from the arm's true joints and the
tool-to-camera offset), eye-to-hand cameras stand still.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, Protocol, cast

import numpy as np

from armtree.api.component_factory import CheckedFactory
from armtree.api.rig import Camera, Frame, RigContext, frame_index
from armtree.config.params import Param
from armtree.errors import ConfigError
from armtree.loader.profile import Profile

from .drawing import world_drawables
from .geometry import look_at, pose, rpy_matrix
from .renderer import CameraModel, Renderer
from .world import World, world_for

#: Camera in the tool frame for the Dobot's eye-in-hand webcam (Showers 2016): looking
#: down with R_TC = [[0, 1, 0], [1, 0, 0], [0, 0, -1]] and P_CT = (-10.48, -21.58,
#: 28.42) mm (eq. 17), the tool seen from the camera, so the camera sits at -R_TC P_CT.
DOBOT_R_TC = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
DOBOT_P_CT = np.array([-10.48, -21.58, 28.42])
DOBOT_CAMERA_IN_TOOL = -DOBOT_R_TC @ DOBOT_P_CT


def camera_extrinsics(config: dict[str, Any]) -> np.ndarray:
    """The camera's 4x4 pose: in the tool frame (eye-in-hand) or the base frame (eye-to-hand)."""
    mount = config.get("mount", "eye_to_hand")
    if mount == "eye_in_hand":
        position = config.get("position") or DOBOT_CAMERA_IN_TOOL.tolist()
        rpy = config.get("rotation_rpy_deg")
        rotation = DOBOT_R_TC if rpy is None else rpy_matrix(*rpy)
        return pose(rotation, position)
    position = np.asarray(config.get("position") or [250.0, 0.0, 700.0], dtype=float)
    rpy = config.get("rotation_rpy_deg")
    if rpy is not None:
        return pose(rpy_matrix(*rpy), position)
    target = np.asarray(config.get("look_at") or [position[0], position[1], 0.0], dtype=float)
    return look_at(position, target)


class SimCamera(Camera):
    """A camera that renders the simulated world; deterministic for the run's seed."""

    #: Frames a second on the run's clock: always known, the frames are rendered at it.
    fps: float

    def __init__(self, config: dict[str, Any], context: RigContext) -> None:
        self.config = dict(config)
        self._context = context
        self.mount = self.config.get("mount", "eye_to_hand")
        self.width = int(self.config.get("width", 640))
        self.height = int(self.config.get("height", 480))
        self.fps = float(self.config.get("fps", 30.0))
        intr = self.config.get("intrinsics") or {}
        self.camera_matrix = np.array(
            [
                [float(intr.get("fx", self.width)), 0.0, float(intr.get("cx", self.width / 2))],
                [0.0, float(intr.get("fy", self.width)), float(intr.get("cy", self.height / 2))],
                [0.0, 0.0, 1.0],
            ]
        )
        self.distortion = np.zeros(5)
        dist = np.asarray(self.config.get("distortion") or [0.0] * 5, dtype=float)
        self.distortion[: min(5, len(dist))] = dist[:5]
        #: Where the profile says the camera is (its position / look_at / rotation): how it
        #: was mounted, as far as anyone knows; the world's ``as_built.camera`` moves it.
        self.nominal = camera_extrinsics(self.config)
        #: Where the camera really is (set when the world is known, at :meth:`start`).
        self.mounted = self.nominal
        #: What the skills take the camera's pose to be: a calibrated ``extrinsics``
        #: when the profile (or a calibration file it includes) gives one, else nominal.
        self.extrinsics = (
            np.asarray(self.config["extrinsics"], dtype=float)
            if self.config.get("extrinsics") is not None
            else self.nominal
        )
        self.drop_rate = float(self.config.get("drop_rate", 0.0))
        self._world: World | None = None
        self.renderer: Renderer | None = None
        self._last_index = -1
        self._lock = threading.Lock()
        #: Called with every frame produced (the recorder listens here).
        self.listeners: list[Callable[[Frame], None]] = []
        self.frames_rendered = 0

    def start(self) -> None:
        """Build the renderer for this camera and the world it looks at."""
        if self.renderer is not None:
            return
        self._world = world_for(self._context)
        self.mounted = self._world.scene.as_built.camera(self.nominal)
        # A randomised world may have drawn the sensor's noise, blur and frame drops.
        drawn = self._world.scene.camera
        self.drop_rate = float(drawn.get("drop_rate", self.drop_rate))
        model = CameraModel(self.width, self.height, self.camera_matrix, self.distortion)
        self.renderer = Renderer(
            model,
            self._world.table,
            self._world.scene.light,
            seed=self._world.seed * 1000 + self._world.scene.seed,
            noise=float(drawn.get("noise", self.config.get("noise", 2.5))),
            blur=float(drawn.get("blur", self.config.get("blur", 0.5))),
            exposure=float(self.config.get("exposure_s", 0.02)),
            shadows=bool(self.config.get("shadows", True)),
        )

    def pose(self) -> np.ndarray:
        """The camera's current pose in the base frame (4x4, mm; OpenCV axes)."""
        self.start()
        assert self._world is not None
        return self._world.camera_pose(self.mount, self.mounted)

    def read(self) -> Frame | None:
        """The frame due at the run's current time, rendered now; None if not new or dropped."""
        self.start()
        index = frame_index(self._context.clock.now(), self.fps)
        with self._lock:
            if index <= self._last_index:
                return None
            self._last_index = index
            if self.drop_rate > 0:
                rng = np.random.default_rng([self._context.seed, 13, index])
                if rng.random() < self.drop_rate:
                    return None
            return self._render(index)

    def render_now(self) -> Frame:
        """Render the frame due now even if it was already read (for tools and recordings)."""
        self.start()
        index = frame_index(self._context.clock.now(), self.fps)
        with self._lock:
            return self._render(index)

    def _render(self, index: int) -> Frame:
        assert self._world is not None and self.renderer is not None
        cam_pose = self._world.camera_pose(self.mount, self.mounted)
        drawables = world_drawables(self._world)
        if self.mount == "eye_in_hand":
            drawables = [d for d in drawables if not d.tool_mounted]
        # The blur of the camera's own motion comes from where it was a tick ago, not
        # from the frame rendered last: a look may read its first frame seconds later.
        motion = self._world.camera_motion(self.mount, self.mounted)
        previous, frame_dt = motion if motion is not None else (None, 1.0 / self.fps)
        image = self.renderer.render(cam_pose, drawables, index, previous, frame_dt)
        self.frames_rendered += 1
        frame = Frame(
            image=image,
            timestamp=index / self.fps,
            camera_matrix=self.camera_matrix.copy(),
            distortion=self.distortion.copy(),
            index=index,
        )
        for listener in self.listeners:
            listener(frame)
        return frame


def _check(config: dict[str, Any]) -> None:
    mount = config.get("mount", "eye_to_hand")
    if mount not in ("eye_in_hand", "eye_to_hand"):
        raise ConfigError(f"camera.mount: expected eye_in_hand or eye_to_hand, got {mount!r}")
    for key in ("width", "height"):
        if int(config.get(key, 1)) <= 0:
            raise ConfigError(f"camera.{key}: must be positive")
    if float(config.get("fps", 30.0)) <= 0:
        raise ConfigError("camera.fps: must be positive")
    if not 0.0 <= float(config.get("drop_rate", 0.0)) < 1.0:
        raise ConfigError("camera.drop_rate: must be in [0, 1)")
    intr = config.get("intrinsics") or {}
    for key, value in intr.items():
        if key not in ("fx", "fy", "cx", "cy"):
            raise ConfigError(f"camera.intrinsics.{key}: unknown; give fx, fy, cx and cy (pixels)")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not -1e6 < value < 1e6:
            raise ConfigError(
                f"camera.intrinsics.{key}: expected a number of pixels, got {value!r}"
            )
    for key in ("fx", "fy"):
        if key in intr and intr[key] <= 0:
            raise ConfigError(f"camera.intrinsics.{key}: must be positive (pixels)")
    for key, size in (("position", 3), ("rotation_rpy_deg", 3), ("look_at", 3)):
        if config.get(key) and len(config[key]) != size:
            raise ConfigError(f"camera.{key}: expected {size} numbers, got {len(config[key])}")
    try:
        extrinsics = camera_extrinsics(config)
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"camera: {exc}") from exc
    believed = config.get("extrinsics")
    if believed is not None:
        arr = np.asarray(believed, dtype=float) if _numbers(believed) else np.zeros(0)
        if arr.shape != (4, 4) or not np.all(np.isfinite(arr)):
            raise ConfigError(f"camera.extrinsics: a 4x4 matrix of numbers (mm), got {believed!r}")
    if not np.all(np.isfinite(extrinsics)):
        raise ConfigError("camera.look_at: the camera cannot look at its own position")


def _numbers(value: Any) -> bool:
    return isinstance(value, list) and all(
        isinstance(row, list)
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in row)
        for row in value
    )


def _validate(config: dict[str, Any], profile: Profile) -> None:
    """Load-time checks (``armtree check``): the profile's camera without rendering anything."""
    _check(config)


def sim_camera(config: dict[str, Any], context: RigContext) -> SimCamera:
    """A simulated camera rendering the profile's world (eye-in-hand or eye-to-hand)."""
    _check(config)
    return SimCamera(config, context)


class _SimCameraFactory(CheckedFactory[SimCamera], Protocol):
    """:func:`sim_camera` with its members: ``simulated(config)`` is always True."""

    simulated: Callable[[dict[str, Any]], bool]


# mypy types a def as a plain callable, which has no attributes to set: the same function,
# typed as what it is once its members are set.
sim_camera = cast(_SimCameraFactory, sim_camera)
sim_camera.validate = _validate
sim_camera.simulated = lambda config: True  # it renders the world: no device behind it
sim_camera.PARAMS = (
    Param(
        "mount",
        "str",
        "eye_to_hand",
        doc="where the camera is fixed",
        choices=("eye_in_hand", "eye_to_hand"),
    ),
    Param("width", "int", 640, "px", "image width", minimum=16, maximum=4096),
    Param("height", "int", 480, "px", "image height", minimum=16, maximum=4096),
    Param(
        "fps",
        "float",
        30.0,
        "Hz",
        "frames per second on the run's clock",
        exclusive_minimum=0.0,
        maximum=1000.0,
    ),
    Param("intrinsics", "dict", {}, "px", "fx, fy, cx, cy (default fx = fy = width, centred)"),
    Param(
        "distortion",
        "vector",
        [0.0, 0.0, 0.0, 0.0, 0.0],
        "",
        "OpenCV k1, k2, p1, p2, k3",
        minimum=-100.0,
        maximum=100.0,
        max_items=8,
    ),
    Param(
        "position",
        "vector",
        [],
        "mm",
        "camera origin in the tool frame (eye_in_hand) or base frame (eye_to_hand)",
        minimum=-10000.0,
        maximum=10000.0,
        max_items=3,
    ),
    Param(
        "rotation_rpy_deg",
        "vector",
        None,
        "deg",
        "camera axes (OpenCV) as roll, pitch, yaw; default looks down",
        minimum=-360.0,
        maximum=360.0,
        length=3,
    ),
    Param(
        "extrinsics",
        "list",
        None,
        "mm",
        "4x4 camera pose the skills use (a calibration's): where position/look_at put it by default",
    ),
    Param(
        "look_at",
        "vector",
        [],
        "mm",
        "eye_to_hand: the base-frame point the camera faces",
        minimum=-10000.0,
        maximum=10000.0,
        max_items=3,
    ),
    Param(
        "noise",
        "float",
        2.5,
        "",
        "sensor noise, standard deviation in grey levels",
        minimum=0.0,
        maximum=255.0,
    ),
    Param(
        "blur",
        "float",
        0.5,
        "px",
        "lens blur (Gaussian sigma); 0 for none",
        minimum=0.0,
        maximum=50.0,
    ),
    Param(
        "exposure_s", "float", 0.02, "s", "exposure time, for motion blur", minimum=0.0, maximum=1.0
    ),
    Param(
        "drop_rate",
        "float",
        0.0,
        "",
        "fraction of frames lost, deterministic for the seed",
        minimum=0.0,
        maximum=0.99,
    ),
    Param("shadows", "bool", True, "", "draw shadows cast by the lamp"),
)
