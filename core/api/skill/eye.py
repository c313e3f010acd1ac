"""One reader of the rig's camera, shared by every skill and condition of a run.

A camera hands each frame out once (``Camera.read`` returns None until the next
one), and locating markers costs milliseconds a frame, so the behaviours of a
tree must not each read and detect on their own: a condition ticked every tick
would take the frame an action was waiting for, and render and detect twenty
times a simulated second. :class:`Eye` reads a frame, locates its markers in the
arm's base frame once (through the profile's vision correction, Durovic 2017 eq. 8,
when a calibration gives one), and keeps the newest :class:`View` for everyone.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from armtree.api.rig import Detection, Rig, needed
from armtree.config.calibration import calibration_of
from armtree.config.workcell import workcell_of
from armtree.maths.perception.frames import camera_in_base, marker_in_base


@dataclass
class Sighting:
    """A marker seen in one frame: its role and id, and its pose in the base frame (4x4 mm)."""

    role: str
    id: int
    pose: np.ndarray
    detection: Detection
    timestamp: float

    @property
    def position(self) -> np.ndarray:
        """The marker centre in the base frame, mm."""
        return self.pose[:3, 3].copy()


@dataclass
class View:
    """One frame's markers: when it was taken (s, run clock), and the tool pose it was seen from."""

    index: int
    timestamp: float
    read_at: float
    tool: np.ndarray
    sightings: list[Sighting] = field(default_factory=list)
    #: The camera's pose in the base frame (4x4 mm) and its view angles: half the image
    #: width and height over the focal lengths (tangents).
    camera: np.ndarray = field(default_factory=lambda: np.eye(4))
    half_view: tuple[float, float] = (0.4, 0.3)

    def footprint(self, z: float) -> tuple[float, float]:
        """Width and height (mm) of the table seen at height ``z`` from a camera looking down."""
        distance = max(0.0, float(self.camera[2, 3]) - z)
        return 2.0 * distance * self.half_view[0], 2.0 * distance * self.half_view[1]

    def of(self, role: str) -> list[Sighting]:
        """The sightings of tag role ``role``."""
        return [s for s in self.sightings if s.role == role]


#: A marker measured within this of the height the profile gives its role (mm) is taken
#: to stand there (``workcell.marker_heights_mm``).
PLANE_TOLERANCE_MM = 25.0


def onto_plane(camera: np.ndarray, point: np.ndarray, z: float) -> np.ndarray:
    """``point`` moved along the camera's ray through it to height ``z`` (mm, base frame)."""
    origin = np.asarray(camera, dtype=float)[:3, 3]
    ray = np.asarray(point, dtype=float) - origin
    if abs(ray[2]) < 1e-9:
        return np.asarray(point, dtype=float)
    return origin + ray * ((z - origin[2]) / ray[2])


class Eye:
    """The newest frame of a rig's camera and the markers in it, read and detected once.

    A marker's range along the camera's ray is what a monocular pose measures worst
    (from 650 mm a 25 mm marker is 22 px wide: half a pixel is 15 mm of range), its
    direction best. Where the profile gives a tag role's marker height above the
    table (``workcell.marker_heights_mm``) and a marker is measured within
    :data:`PLANE_TOLERANCE_MM` of it, it is put at that height along its ray.
    """

    def __init__(self, rig: Rig) -> None:
        self.rig = rig
        self.last: View | None = None
        self.frames = 0
        #: The newest sighting of every marker seen this run, by id, and when it was read
        #: (s, run clock): where objects beside a grip stand when the last frame missed them.
        self.seen: dict[int, Sighting] = {}
        self.seen_at: dict[int, float] = {}
        cell = workcell_of(getattr(rig, "profile", None))
        table = cell.table_z_mm
        self.planes = (
            {} if table is None else {role: table + h for role, h in cell.marker_heights_mm.items()}
        )
        #: The profile's linear correction of what vision measures (Durovic 2017, eq. 8), if any.
        self.calibration = calibration_of(getattr(rig, "profile", None))

    def newest(self) -> View | None:
        """The view of a frame that arrived since the last read, else the last view (or None)."""
        rig = self.rig
        camera, tracker = needed(rig.camera, "camera"), needed(rig.tracker, "tracker")
        frame = camera.read()
        if frame is None:
            return self.last
        self.frames += 1
        tool = rig.arm.pose() if rig.arm is not None else np.eye(4)
        base_T_camera = camera_in_base(camera.mount, camera.extrinsics, tool)
        seen: dict[int, Sighting] = {}
        for det in tracker.detect(frame):
            if det.tvec is None:
                continue
            role = det.role
            if role in ("", "unknown"):
                spec = rig.role_of(det.id)
                role = spec.role if spec is not None else "unknown"
            pose = marker_in_base(base_T_camera, det.rvec, det.tvec)
            plane = self.planes.get(role)
            if plane is not None and abs(pose[2, 3] - plane) <= PLANE_TOLERANCE_MM:
                pose[:3, 3] = onto_plane(base_T_camera, pose[:3, 3], plane)
            pose[:3, 3] = self.calibration.seen(pose[:3, 3])
            seen[det.id] = Sighting(role, det.id, pose, det, frame.timestamp)
        now = rig.clock.now()
        for marker, sighting in seen.items():
            plane = self.planes.get(sighting.role)
            if plane is not None and sighting.pose[2, 3] > plane + PLANE_TOLERANCE_MM:
                self.forget(marker)  # off the table (carried): it stands nowhere now
            else:
                self.seen[marker], self.seen_at[marker] = sighting, now
        k = np.asarray(frame.camera_matrix, dtype=float)
        h, w = frame.image.shape[:2]
        half = (0.5 * w / k[0, 0], 0.5 * h / k[1, 1]) if k[0, 0] > 0 and k[1, 1] > 0 else (0.4, 0.3)
        self.last = View(
            frame.index,
            frame.timestamp,
            now,
            tool,
            list(seen.values()),
            base_T_camera,
            half,
        )
        return self.last

    def forget(self, marker: int) -> None:
        """Drop marker ``marker`` from :attr:`seen`: it was gripped away from where it was."""
        self.seen.pop(marker, None)
        self.seen_at.pop(marker, None)

    def recent(self, max_age: float) -> View | None:
        """A view read at most ``max_age`` seconds ago, reading a new frame only when the
        last is older (conditions ticked every tick read a few frames a second, not twenty)."""
        last = self.last
        if last is not None and self.rig.clock.now() - last.read_at <= max_age + 1e-9:
            return last
        return self.newest()


@dataclass
class Tally:
    """What the looks of one search saw, to say why it did not find its tag.

    ``frames`` read, the tag ``roles`` seen, the ``unknown`` ids (markers no tag
    role has), and ``unread``: the most marker-like shapes one frame that did not
    show the wanted tag left unread in the tracker's family (``Tracker.unread``).
    """

    frames: int = 0
    roles: set[str] = field(default_factory=set)
    unknown: set[int] = field(default_factory=set)
    unread: int = 0

    def add(self, view: View, tracker: Any, wanted: bool) -> None:
        """Count ``view``, the frame ``tracker`` detected last; ``wanted``: it showed the tag."""
        self.frames += 1
        for s in view.sightings:
            if s.role == "unknown":
                self.unknown.add(s.id)
            else:
                self.roles.add(s.role)
        if not wanted:
            # asked only here: the aruco tracker counts these when asked; a tracker
            # that does not subclass armtree.api.rig.Tracker counts none
            self.unread = max(self.unread, int(getattr(tracker, "unread", 0)))

    def describe(self, family: str | None) -> str:
        """What was seen, for a failure message: shapes of another family, markers of other
        roles or of no role, or nothing at all."""
        if self.unread:
            shapes = f"{self.unread} marker-like shape" + ("s" * (self.unread > 1))
            return (
                f"{shapes} in a frame decoded as nothing in family {family or 'of the tracker'}: "
                "the markers may be of another family"
            )
        seen = [f"{role!r}" for role in sorted(self.roles)]
        if self.unknown:
            ids = ", ".join(str(i) for i in sorted(self.unknown)[:5])
            seen.append(f"markers {ids} of no tag role")
        if seen:
            return f"saw {', '.join(seen)}"
        return f"no marker in any of {self.frames} frames"


def eye_of(rig: Rig) -> Eye:
    """The rig's :class:`Eye` (:attr:`Rig.eye <armtree.api.rig.Rig.eye>`), made on first use."""
    eye = getattr(rig, "eye", None)
    if eye is None or eye.rig is not rig:
        eye = rig.eye = Eye(rig)
    return eye


__all__ = ["Eye", "PLANE_TOLERANCE_MM", "Sighting", "Tally", "View", "eye_of", "onto_plane"]
