"""Missed steps noticed with the camera while a calibration or experiment visits its poses.

A stepper arm without encoders cannot report a step it missed: from then on it
believes its joints are where they are not, until it homes on its own reference
(end stops). The camera can see it. :class:`SlipWatch` does it two ways:

* ``joints``: at each pose, where the camera puts the tool's marker (along its ray
  at the height the joints give it) against where the joints put it. Needs a fixed
  camera whose pose is calibrated: its own error must stay well below ``slip_mm``.
* ``reference``: one pose (the one nearest the middle of the camera's view) is
  looked at again every few poses; a slip that
  came in between moves where the camera sees the marker there. Needs no
  calibration at all (the same pose, seen by the same camera), so a hand-eye
  calibration can use it. The reference view itself is taken twice, with a homing
  between, so that a slip before the check pose is not taken for the truth.

When the camera finds the arm moved, the arm homes (``ArmHome``) and measures again
what the slip may have spoiled: the pose, or the poses since the last good look.
Homing that changes nothing (an arm without end stops, whose homing is a move, or
a camera that is off) and slips that keep coming fail the step with the reason.
Units: mm.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from armtree.api.rig import Rig
from armtree.api.skill.actions import ArmHome, SkillFailure, fmt
from armtree.api.skill.base import Procedure
from armtree.maths.perception.frames import EYE_IN_HAND
from armtree.maths.perception.hand_eye import lateral_residuals

from . import fits

CHECKS = ("joints", "reference")
#: A pose seen again differs by the frames' noise alone (hundredths of a mm): a change
#: below this fraction of ``slip_mm`` across a homing means the homing changed nothing.
UNCHANGED = 0.25


def offset(record: dict[str, Any], rig: Rig) -> np.ndarray:
    """Where the camera puts the tool less where the joints say it is at one visited pose
    (mm, x-y); zero where the marker was not seen or the pose not reached (nothing to check)."""
    if not (record.get("reached") and record.get("seen")):
        return np.zeros(2)
    seen = fits.vision_tool_positions([record], rig)[0]
    return seen[:2] - np.asarray(record["tool_pose"])[:2, 3]


def moved(a: dict[str, Any], b: dict[str, Any]) -> float:
    """How far (mm, across the line of sight) the camera saw the marker move between two
    visits of the same pose."""
    return float(lateral_residuals(np.array([a["tvec"]]), np.array([b["tvec"]]))[0])


class SlipWatch:
    """Checks ``skill``'s visits (a ``visit_poses``) for missed steps and redoes what they
    spoiled; counts the homings. ``slip_mm`` 0 checks nothing."""

    def __init__(self, skill: Any, role: str, slip_mm: float, redo: int) -> None:
        self.skill, self.role, self.slip, self.redo = skill, role, float(slip_mm), int(redo)
        self.mode = ""
        #: Looks at the camera for a slip; those that found the arm moved; homings; visits
        #: of poses made again because a slip may have spoiled them.
        self.checks = self.found = self.homings = self.redone = 0
        #: Poses measured and kept so far (for the progress bar); the pose looked at again.
        self.done = self.check_index = 0

    def summary(self) -> dict[str, Any] | None:
        """What the watch did, for the observations (None when it checked nothing)."""
        if not self.slip:
            return None
        return {"check": self.mode, "slip_mm": self.slip, "checks": self.checks,
                "found": self.found, "homings": self.homings, "redone": self.redone}  # fmt: skip

    def _fail(self, what: str) -> SkillFailure:
        return SkillFailure(f"{self.skill.name}: {what}")

    def _home(self, why: str) -> Procedure:
        self.homings += 1
        self.skill.note("rehome", why=why)
        yield ArmHome(self.skill.rig)

    # ------------------------------------------------------------------ joints

    def by_joints(self, k: int, pose: np.ndarray, total: int) -> Procedure:
        """Visit pose ``k``; while the camera and the joints disagree by more than
        ``slip_mm``, home and visit it again. The record, with ``disagreement_mm`` and
        ``redone`` (without them when ``slip_mm`` is 0)."""
        self.mode = "joints"
        skill, rig = self.skill, self.skill.rig
        record = yield from skill.visit_pose(k, pose, self.role, total)
        if not self.slip:
            return record
        self.checks += 1
        redone, last = 0, np.zeros(2)
        while np.linalg.norm(off := offset(record, rig)) > self.slip:
            self.found += 1
            far = float(np.linalg.norm(off))
            where = f"at pose {k + 1} ({fmt(pose)}) the camera and the joints"
            if redone == self.redo:
                raise self._fail(f"{where} still disagree by {far:.2f} mm after the arm homed "
                                 f"{redone} times, each time by something else: steps keep slipping")  # fmt: skip
            if redone and np.linalg.norm(off - last) <= UNCHANGED * self.slip:
                raise self._fail(f"{where} disagree by {far:.2f} mm, as much after the arm homed: its "
                                 "homing does not re-reference it (no end stops), or the camera's pose "
                                 "is off (calibrate hand-eye first, or set slip_mm 0)")  # fmt: skip
            redone, last = redone + 1, off
            yield from self._home(f"pose {k + 1}: camera and joints disagree by {far:.2f} mm")
            record = yield from skill.visit_pose(k, pose, self.role, total)
            self.checks += 1
        self.redone += redone
        record["disagreement_mm"] = round(float(np.linalg.norm(offset(record, rig))), 4)
        record["redone"] = redone
        return record

    # ------------------------------------------------------------------ reference

    def by_reference(self, poses: list[np.ndarray], every: int) -> Procedure:
        """Visit ``poses`` in runs of ``every``, each followed by a look at the check pose;
        a run after which the camera sees the marker moved there is visited again after
        homing. The records, each with ``redone`` (how often its run was visited again)."""
        self.mode = "reference"
        if not poses:
            return []
        self.check_index = self._central(poses)
        check = poses[self.check_index]
        reference = yield from self._reference(check, len(poses))
        out: list[dict[str, Any]] = []
        start, redone = 0, 0
        while start < len(poses):
            run = range(start, min(start + every, len(poses)))
            records = []
            for k in run:
                records.append(
                    (yield from self.skill.visit_pose(k, poses[k], self.role, len(poses)))
                )
            now = yield from self._look(check, len(poses))
            self.checks += 1
            if moved(now, reference) <= self.slip:
                for r in records:
                    r["redone"] = redone
                out += records
                start, redone, self.done = run.stop, 0, run.stop
                continue
            self.found += 1
            if redone == self.redo:
                raise self._fail(f"poses {run.start + 1}-{run.stop}: the arm missed steps each of "
                                 f"the {redone + 1} times it visited them: steps keep slipping")  # fmt: skip
            redone += 1
            self.redone += len(run)
            yield from self._back_to(reference, now, check, len(poses),
                                     f"poses {run.start + 1}-{run.stop}")  # fmt: skip
        return out

    def _central(self, poses: list[np.ndarray]) -> int:
        """The pose whose marker the camera sees nearest the middle of its view (as the
        profile places the camera), where it is seen best: the one looked at again."""
        camera = getattr(self.skill.rig, "camera", None)
        if camera is None or camera.mount == EYE_IN_HAND or self.skill.workcell.tool_marker is None:
            return 0
        lift = np.array([0.0, 0.0, self.skill.workcell.tool_marker.offset_mm[2]])
        cam_T_base = np.linalg.inv(np.asarray(camera.extrinsics, dtype=float))
        seen = (np.array(poses) + lift) @ cam_T_base[:3, :3].T + cam_T_base[:3, 3]
        return int(np.argmin(np.linalg.norm(seen[:, :2] / seen[:, 2:3], axis=1)))

    def _look(self, pose: np.ndarray, total: int) -> Procedure:
        """Visit the pose looked at again (the reference) and look: its record, the marker seen."""
        record = yield from self.skill.visit_pose(
            self.check_index, pose, self.role, total, "look for missed steps", self.done
        )
        if not record.get("seen"):
            why = record.get("why") or "the camera did not see the marker"
            raise self._fail(f"the check pose ({fmt(pose)}), where missed steps are looked for: "
                             f"{why}; choose other poses")  # fmt: skip
        return record

    def _reference(self, pose: np.ndarray, total: int) -> Procedure:
        """The reference view of the check pose: two looks with a homing between that agree."""
        before = yield from self._look(pose, total)
        self.checks += 1
        for _ in range(self.redo):
            yield from self._home("the reference view of the check pose")
            after = yield from self._look(pose, total)
            self.checks += 1
            if moved(after, before) <= self.slip:
                return after
            self.found += 1
            before = after
        raise self._fail(f"the check pose ({fmt(pose)}) was seen somewhere else after each of "
                         f"{self.redo} homings: steps keep slipping")  # fmt: skip

    def _back_to(self, reference: dict[str, Any], now: dict[str, Any], pose: np.ndarray,
                 total: int, spoiled: str) -> Procedure:  # fmt: skip
        """Home until the check pose is seen where the reference saw it."""
        far = moved(now, reference)
        for _ in range(self.redo):
            yield from self._home(f"{spoiled}: the check pose seen {far:.2f} mm from the reference")
            after = yield from self._look(pose, total)
            self.checks += 1
            if moved(after, reference) <= self.slip:
                return
            self.found += 1
            if moved(after, now) <= UNCHANGED * self.slip:
                raise self._fail(
                    f"after {spoiled} the check pose ({fmt(pose)}) is seen {far:.2f} mm from "
                    "where it was, as much after the arm homed: its homing does not "
                    "re-reference it (no end stops)"
                )
            now, far = after, moved(after, reference)
        raise self._fail(f"the check pose ({fmt(pose)}) was seen somewhere else after each of "
                         f"{self.redo} homings: steps keep slipping")  # fmt: skip


__all__ = ["CHECKS", "SlipWatch", "moved", "offset"]
