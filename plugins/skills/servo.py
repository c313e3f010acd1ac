"""Visual servoing to a marker (seed 000, section III.C, steps 1-7).

Each iteration measures where the tool is and where it should be through the
camera, turns both into joint angles by inverse kinematics and sends the
difference to the arm, until the error is below the tolerance (3 mm in the
paper's experiments) or the iterations run out.
"""

from __future__ import annotations

import numpy as np

from armtree import Param, Unreachable
from armtree.perception.frames import LinearCorrection

from .actions import Look, Move, SkillFailure, fmt
from .base import Procedure
from .manipulation import ArmSkill


class VisualServo(ArmSkill):
    """Bring the tool to ``offset`` from a target marker by measuring and correcting.

    Eye-in-hand: the target marker is measured through the camera on the tool
    and the tool position comes from the joints; once the tool is over the
    target the camera may no longer see it, and its last measurement stands. Eye-to-hand with ``tool_tag``:
    the tool's own marker is measured too (seed 000's set-up), so errors of the
    arm's open-loop positioning are corrected as well. SUCCESS when the error is
    below ``tolerance_mm``; FAILURE after ``max_iterations`` or when a marker is
    not in view.
    """

    PARAMS = (
        Param("tag", "str", doc="tag role of the target marker", kind="tag_role"),
        Param(
            "offset",
            "vector",
            [0.0, 0.0, 0.0],
            "mm",
            "wanted tool position relative to the target marker",
            minimum=-5000.0,
            maximum=5000.0,
            length=3,
        ),
        Param(
            "tool_tag",
            "str",
            "",
            "",
            "tag role of a marker on the tool (eye-to-hand servoing)",
            kind="tag_role",
        ),
        Param(
            "marker_offset",
            "vector",
            [0.0, 0.0, 0.0],
            "mm",
            "the tool marker's position in the tool frame",
            minimum=-5000.0,
            maximum=5000.0,
            length=3,
        ),
        Param(
            "tolerance_mm",
            "float",
            3.0,
            "mm",
            "stop when the error is below this (seed 000: 3 mm)",
            exclusive_minimum=0.0,
            maximum=1000.0,
        ),
        Param(
            "max_iterations", "int", 10, "", "corrections before giving up", minimum=1, maximum=1000
        ),
        Param(
            "gain",
            "float",
            1.0,
            "",
            "fraction of the measured joint error sent per iteration",
            exclusive_minimum=0.0,
            maximum=2.0,
        ),
        Param(
            "correction",
            "vector",
            [1.0, 0.0, 1.0, 0.0],
            "",
            "seed 000 eq. 8 map [a_x, b_x, a_y, b_y] of measured positions",
            minimum=-1e6,
            maximum=1e6,
            length=4,
        ),
        Param("frames", "int", 2, "", "frames to read per measurement", minimum=1, maximum=100),
        Param("error", "any", None, "mm", "output: the last measured error", io="out"),
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm",)
    NEEDS = ("arm", "camera")

    def procedure(self) -> Procedure:
        tag, tool_tag = self.param("tag"), self.param("tool_tag")
        offset = np.asarray(self.param("offset"), dtype=float)
        correction = LinearCorrection(*(float(v) for v in self.param("correction")))
        arm, model = self.rig.arm, self.rig.arm.model
        tolerance = float(self.param("tolerance_mm"))
        error = float("inf")
        last: np.ndarray | None = None
        for iteration in range(self.param("max_iterations") + 1):
            # step 1-2: marker positions in the camera, then in the robot frame
            sightings = yield Look(
                self.rig, self.clock, want=tag, frames=self.param("frames"), settle=self.settle()
            )
            target = next((s for s in sightings if s.role == tag), None)
            if target is not None:
                last = correction.apply(target.position)
            elif last is None or tool_tag:
                raise SkillFailure(f"{self.name}: the target {tag!r} tag is not in view")
            # eye-in-hand: the camera cannot see under the tool, so a target that left
            # the view after a correction keeps its last measured (fixed) position
            reference = last + offset
            q = np.asarray(arm.joints(), dtype=float)
            if tool_tag:
                mark = next((s for s in sightings if s.role == tool_tag), None)
                if mark is None:
                    raise SkillFailure(f"{self.name}: the tool's {tool_tag!r} tag is not in view")
                rot = model.fk(q)[:3, :3]
                measured = correction.apply(mark.position) - rot @ np.asarray(
                    self.param("marker_offset"), dtype=float
                )
            else:
                measured = model.position(q)
            error = float(np.linalg.norm(reference - measured))
            self.output("error", round(error, 3))
            if error < tolerance:
                self.feedback_message = (
                    f"within {error:.2f} mm of {fmt(reference)} after {iteration} corrections"
                )
                return error
            if iteration == self.param("max_iterations"):
                break
            try:
                q_meas = model.ik(measured, near=q)  # step 3
                q_ref = model.ik(reference, near=q)  # steps 4-5
            except Unreachable as exc:
                raise SkillFailure(f"{self.name}: {exc}") from exc
            dq = q_ref - q_meas  # step 6
            yield Move(
                self.rig, joints=q + self.param("gain") * dq, speed=self.speed(), label="servo"
            )  # step 7
        raise SkillFailure(
            f"{self.name}: error still {error:.2f} mm after {self.param('max_iterations')} corrections "
            f"(tolerance {tolerance:g} mm)"
        )
