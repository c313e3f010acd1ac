"""Follow a moving marker with the camera (Showers 2016, appendices C and D).

The report hovers the camera 5 tag sizes above the marker, smooths the
marker's base-frame position with weight 0.2 on each new measurement, moves
only when the wanted position changed by more than 1 mm, and gives the marker
up after 30 consecutive frames without it.
"""

from __future__ import annotations

import numpy as np

from armtree import Param
from armtree.api.rig import needed
from armtree.api.skill.actions import Look, Move, Pause, SkillFailure, fmt
from armtree.api.skill.arm import ArmSkill, camera_over
from armtree.api.skill.base import Procedure, as_list
from armtree.maths.perception.filters import PoseFilter
from armtree.maths.perception.frames import EYE_IN_HAND

#: The smoothed marker's key in the pose filter (one marker is followed).
_TRACKED = 0
#: Misses in a row after which the camera goes back to where it last saw the marker.
BLIND_AFTER = 3
#: A wanted position this close (mm) to one the marker was lost from is not tried again.
BLIND_RADIUS_MM = 10.0


class Track(ArmSkill):
    """Keep the camera above a moving marker; SUCCESS once it stood still or `until` holds.

    The marker's base position is low-pass filtered (``alpha``, Showers 2016
    appendix D) and written to ``pose``; the arm follows when the wanted
    position moved more than ``deadband_mm``. SUCCESS when the marker moved less
    than ``still_mm`` for ``still_s`` seconds, or when ``until`` (usually a
    ``{key}``) is true; FAILURE when it was missed in ``lost_frames`` frames in a row.
    If following hid the marker (the tool in the view, the edge of the image), the
    camera goes back to where it last saw it and does not try that position again.
    A fixed (eye-to-hand) camera is not moved by the arm, so the arm stays where it is:
    following would only put the tool between the camera and the marker.
    """

    PARAMS = (
        Param("tag", "str", doc="tag role to follow", kind="tag_role"),
        Param(
            "height_mm",
            "float",
            0.0,
            "mm",
            "camera height above the marker (0: 5 tag sizes)",
            minimum=0.0,
            maximum=5000.0,
        ),
        Param(
            "alpha",
            "float",
            0.2,
            "",
            "weight of a new measurement in the smoothed position",
            exclusive_minimum=0.0,
            maximum=1.0,
        ),
        Param(
            "deadband_mm",
            "float",
            1.0,
            "mm",
            "smallest change of the wanted position worth a move",
            minimum=0.0,
            maximum=1000.0,
        ),
        Param(
            "still_mm",
            "float",
            3.0,
            "mm",
            "a marker moving less than this is standing still",
            minimum=0.0,
            maximum=1000.0,
        ),
        Param(
            "still_s",
            "float",
            2.0,
            "s",
            "how long the marker must stand still (0: never ends so)",
            minimum=0.0,
            maximum=86400.0,
        ),
        Param("until", "bool", False, "", "end with SUCCESS when this (a {key}) becomes true"),
        Param(
            "lost_frames",
            "int",
            30,
            "",
            "consecutive frames without the marker before FAILURE",
            minimum=1,
            maximum=1000000,
        ),
        Param(
            "period_s",
            "float",
            0.2,
            "s",
            "time between looks while the arm is still",
            minimum=0.01,
            maximum=3600.0,
        ),
        Param("pose", "any", None, "mm", "output: the marker's smoothed base position", io="out"),
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm",)
    NEEDS = ("arm", "camera")

    def height(self, tag: str) -> float:
        """Camera height above the marker in mm."""
        h = float(self.param("height_mm"))
        if h > 0:
            return h
        spec = self.rig.tags.get(tag)
        return 5.0 * (spec.size_mm if spec is not None else 25.0)

    def procedure(self) -> Procedure:
        tag = self.param("tag")
        height = self.height(tag)
        smoother = PoseFilter(alpha=float(self.param("alpha")))
        missed = 0
        anchor: np.ndarray | None = None
        anchor_t = 0.0
        # the tool position the marker was last seen from, and a wanted position from
        # which it was not (the tool or the view's edge hid it): go back, don't retry
        seen_from: np.ndarray | None = None
        blind: np.ndarray | None = None
        follow = needed(self.rig.camera, "camera").mount == EYE_IN_HAND
        while not self.param("until"):
            if anchor is not None:
                yield Pause(self.clock, float(self.param("period_s")))
            sightings = yield Look(self.rig, self.clock, want=tag, frames=1, settle=self.settle())
            seen = [s for s in sightings if s.role == tag]
            here = needed(self.rig.arm, "arm").pose()[:3, 3]
            if not seen:
                missed += 1
                if missed >= self.param("lost_frames"):
                    raise SkillFailure(f"{self.name}: lost the {tag!r} tag for {missed} frames")
                away = seen_from is not None and np.linalg.norm(here - seen_from) > float(
                    self.param("deadband_mm")
                )
                if follow and missed >= BLIND_AFTER and away:
                    blind = here
                    yield Move(self.rig, seen_from, speed=self.speed(), label="back")
                continue
            missed = 0
            seen_from = here
            measured = seen[0].position
            now = self.clock.now()
            if anchor is None or np.linalg.norm(measured - anchor) > self.param("still_mm"):
                anchor, anchor_t = measured, now
            estimate = smoother.update(_TRACKED, measured, timestamp=now).tvec
            self.output("pose", as_list(estimate))
            still_s = float(self.param("still_s"))
            if still_s > 0 and now - anchor_t >= still_s:
                self.feedback_message = f"{tag!r} still at {fmt(estimate)}"
                return estimate
            if not follow:
                continue
            wanted = camera_over(self, estimate, height)
            if blind is not None and np.linalg.norm(wanted - blind) < BLIND_RADIUS_MM:
                continue
            if np.linalg.norm(wanted - here) > self.param("deadband_mm"):
                yield Move(self.rig, wanted, speed=self.speed(), label="follow")
        return None
