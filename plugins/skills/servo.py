"""Visual servoing to a marker (Durovic 2017, section III.C, steps 1-7, and experiment 2).

Eye-to-hand (Durovic 2017's rig: a fixed camera and a marker on the tool): the target
marker is measured once, before the arm comes near enough to hide it ("after
capturing an image, the center of the target marker ... was determined"); the
arm moves there directly by inverse kinematics; then each iteration measures the
tool's marker, turns the measured and the wanted tool positions into joint
angles and sends the difference (steps 1-7), until the error is below the
tolerance (3 mm in the paper). Because the tool is measured, errors of the
arm's open-loop positioning, missed steps among them, are corrected. A marker's
distance from the camera is the least accurate part of what is measured (the
paper's conclusion), so the tool marker is placed where its ray from the camera
meets the height the joints give it, and a target on the table (``on_table``)
where its ray meets the table top.

Eye-in-hand: the camera on the tool measures the target from where the tool is,
again after each correction while it still sees it (once the tool is over the
target the camera may no longer, and the last measurement stands); the tool's
position comes from the joints, and the target's from the same joints, so a
missed step shifts both alike and the correction still lands on the target.
"""

from __future__ import annotations

import numpy as np
from py_trees.common import Status

from armtree import Param, Unreachable
from armtree.api.rig import needed
from armtree.api.skill.actions import Look, Move, SkillFailure, fmt
from armtree.api.skill.arm import ArmSkill
from armtree.api.skill.base import Procedure
from armtree.api.skill.eye import Sighting
from armtree.api.skill.sightline import joints_out_of_view, shadow
from armtree.maths.perception.frames import EYE_IN_HAND, along_ray_to_height

from .locate import nearest


class VisualServo(ArmSkill):
    """Bring the tool to ``offset`` from a target marker by measuring and correcting.

    Eye-to-hand, the tool's marker is the profile's ``workcell.tool_marker`` (or
    ``tool_tag`` with ``marker_offset``); without one the direct move is all
    that can be done and the error is the joints' word for it. It corrects until
    the error is below ``aim_mm`` (default: the tolerance); SUCCESS when the error
    is then below ``tolerance_mm``; FAILURE when it is not after ``max_iterations``
    corrections, when the target cannot be seen from anywhere the arm gets out
    of its way, or when the tool's marker is out of view (the message says where
    the tool was).
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
            "tag role of a marker on the tool (default: the profile's workcell.tool_marker)",
            kind="tag_role",
        ),
        Param(
            "marker_offset",
            "vector",
            None,
            "mm",
            "the tool marker's centre in the tool frame (default: workcell.tool_marker)",
            minimum=-5000.0,
            maximum=5000.0,
            length=3,
        ),
        Param(
            "on_table",
            "bool",
            False,
            "",
            "the target lies on the table top (workcell.table_z_mm): measured along its ray",
        ),
        Param(
            "tolerance_mm",
            "float",
            3.0,
            "mm",
            "stop when the error is below this (Durovic 2017: 3 mm)",
            exclusive_minimum=0.0,
            maximum=1000.0,
        ),
        Param(
            "aim_mm",
            "float",
            None,
            "mm",
            "correct until the error is below this, nearer than the tolerance "
            "(default: tolerance_mm); the tolerance still decides success",
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
        Param("frames", "int", 3, "", "frames averaged per measurement", minimum=1, maximum=100),
        Param("error", "any", None, "mm", "output: the last measured error", io="out"),
        Param(
            "iterations", "any", None, "", "output: corrections made after the first move", io="out"
        ),
        Param("failure", "any", None, "", "output: why it failed ('' on success)", io="out"),
        *ArmSkill.COMMON,
    )
    RESOURCES = ("arm",)
    NEEDS = ("arm", "camera")

    def update(self) -> Status:
        status = super().update()
        if status is Status.FAILURE:
            self.output("failure", self.feedback_message)
        elif status is Status.SUCCESS:
            self.output("failure", "")
        return status

    def procedure(self) -> Procedure:
        if needed(self.rig.camera, "camera").mount == EYE_IN_HAND:
            return (yield from self._eye_in_hand())
        return (yield from self._eye_to_hand())

    # -- eye-to-hand (Durovic 2017) ------------------------------------------------

    def _eye_to_hand(self) -> Procedure:
        rig, tag = self.rig, self.param("tag")
        tool_tag, marker_offset = self._tool_marker()
        target = yield from self._target_once(tag)
        reference = target + np.asarray(self.param("offset"), dtype=float)
        # experiment 2: "the robot initially moved to this position by setting its
        # joints to the values computed by inverse kinematics"
        yield Move(rig, reference, speed=self.speed(), label="direct move")
        for iteration in range(self.param("max_iterations") + 1):
            q = np.asarray(needed(rig.arm, "arm").joints(), dtype=float)
            if tool_tag:
                mark = yield from self._tool_mark(tool_tag)  # step 1
                # step 2 (the Eye put it in the base frame); the tool centre under the marker
                pose = needed(rig.arm, "arm").model.fk(q)
                lift = pose[:3, :3] @ marker_offset
                seen = along_ray_to_height(self._camera_at(), mark.position, pose[2, 3] + lift[2])
                measured = seen - lift
            else:
                measured = needed(rig.arm, "arm").model.position(q)
            done = yield from self._close(q, measured, reference, iteration)
            if done is not None:
                return done
        raise self._gave_up()

    def _tool_marker(self) -> tuple[str, np.ndarray]:
        """The tool's marker role and its offset in the tool frame (mm); ``""`` for none."""
        role = self.param("tool_tag")
        offset = self.param("marker_offset")
        declared = self.workcell.tool_marker
        if not role and declared is not None:
            role = declared.tag
        if offset is None:
            offset = (
                declared.offset_mm if declared is not None and declared.tag == role else (0, 0, 0)
            )
        return role, np.asarray(offset, dtype=float)

    def _target_once(self, tag: str) -> Procedure:
        """The target's position (mm), averaged over ``frames`` frames; when the arm is in
        the way, measured again with the arm at a survey pose whose links do not hide
        what they hide now (where the target must be)."""
        rig = self.rig
        sighting = yield from self._look_for(tag)
        if sighting is None:
            hidden = shadow(self)
            away = joints_out_of_view(
                self, hidden if len(hidden) else needed(rig.arm, "arm").pose()[:3, 3]
            )
            if away is not None:
                yield Move(rig, joints=away, speed=self.speed(), label="out of the camera's way")
                sighting = yield from self._look_for(tag)
        if sighting is None:
            raise SkillFailure(f"{self.name}: the target {tag!r} tag is not in view")
        if self.param("on_table"):
            table = self.workcell.need("table_z_mm", f"{self.name} (on_table)")
            return along_ray_to_height(self._camera_at(), sighting.position, float(table))
        return sighting.position

    def _camera_at(self) -> np.ndarray:
        """The fixed camera's position in the base frame (mm), as the profile gives it."""
        return np.asarray(needed(self.rig.camera, "camera").extrinsics, dtype=float)[:3, 3]

    def _look_for(self, role: str) -> Procedure:
        sightings = yield Look(
            self.rig, self.clock, frames=self.param("frames"), settle=self.settle(), average=True
        )
        return nearest(sightings, role, None)

    def _tool_mark(self, role: str) -> Procedure:
        """The tool marker's sighting; a second look before giving up (one frame may miss it)."""
        for _ in range(2):
            mark = yield from self._look_for(role)
            if mark is not None:
                return mark
        where = fmt(needed(self.rig.arm, "arm").pose()[:3, 3])
        raise SkillFailure(
            f"{self.name}: the tool's {role!r} marker is not in view with the tool at {where} "
            "(the arm hides it or it is outside the image there)"
        )

    # -- eye-in-hand ---------------------------------------------------------------

    def _eye_in_hand(self) -> Procedure:
        rig, tag = self.rig, self.param("tag")
        offset = np.asarray(self.param("offset"), dtype=float)
        last: Sighting | None = None
        for iteration in range(self.param("max_iterations") + 1):
            sightings = yield Look(
                rig, self.clock, want=tag, frames=self.param("frames"), settle=self.settle()
            )
            seen = nearest(sightings, tag, None if last is None else last.position)
            if seen is not None:
                last = seen
            elif last is None:
                raise SkillFailure(f"{self.name}: the target {tag!r} tag is not in view")
            # the camera cannot see under the tool: a target that left the view after a
            # correction keeps its last measured (fixed) position
            reference = last.position + offset
            q = np.asarray(needed(rig.arm, "arm").joints(), dtype=float)
            measured = needed(rig.arm, "arm").model.position(q)
            done = yield from self._close(q, measured, reference, iteration)
            if done is not None:
                return done
        raise self._gave_up()

    # -- steps 3-7 -------------------------------------------------------------------

    def _close(
        self, q: np.ndarray, measured: np.ndarray, reference: np.ndarray, iteration: int
    ) -> Procedure:
        """The error (mm) when the loop is done; else None, after sending the correction.

        Done when the error is below the aim (``aim_mm``, at most the tolerance), or
        after the last iteration when it is below the tolerance: aiming nearer than the
        tolerance keeps a direct move that lands just inside it from staying there.
        Outputs the error either way.
        """
        self._error = float(np.linalg.norm(reference - measured))
        self.output("error", round(self._error, 3))
        self.output("iterations", iteration)
        tolerance = float(self.param("tolerance_mm"))
        aim = self.param("aim_mm")
        aim = tolerance if aim is None else min(float(aim), tolerance)
        last = iteration >= self.param("max_iterations")
        if self._error < aim or (last and self._error < tolerance):
            self.feedback_message = (
                f"within {self._error:.2f} mm of {fmt(reference)} after {iteration} corrections"
            )
            return self._error
        if not last:
            yield self._correction(q, measured, reference)
        return None

    def _correction(self, q: np.ndarray, measured: np.ndarray, reference: np.ndarray) -> Move:
        """Steps 3-7: joints of the measured and the wanted positions, their difference sent."""
        model = needed(self.rig.arm, "arm").model
        try:
            q_meas = model.ik(measured, near=q)  # step 3
            q_ref = model.ik(reference, near=q)  # steps 4-5
        except Unreachable as exc:
            raise SkillFailure(f"{self.name}: {exc}") from exc
        dq = q_ref - q_meas  # step 6
        # Missed steps shift the reported joints: near a limit the full correction may
        # leave it, so as much of it as stays within is sent, and the next look decides.
        gain = float(self.param("gain"))
        for _ in range(6):
            target = q + gain * dq
            if model.within_limits(target):
                return Move(self.rig, joints=target, speed=self.speed(), label="servo")  # step 7
            gain *= 0.5
        raise SkillFailure(
            f"{self.name}: the correction from joints {np.round(q, 2).tolist()} leaves the arm's "
            "joint limits (missed steps may have shifted its reported joints: home it)"
        )

    def _gave_up(self) -> SkillFailure:
        return SkillFailure(
            f"{self.name}: error still {self._error:.2f} mm after "
            f"{self.param('max_iterations')} corrections "
            f"(tolerance {float(self.param('tolerance_mm')):g} mm)"
        )
