"""Behaviours of Durovic 2017's experiment 2: targets placed one after another, the tool servoed
over each, the distance measured from outside.

``plan_targets`` draws table points where the target can lie: the tool reaches
``hover_mm`` above it, with a fixed camera the camera sees the tool's marker
there, and nothing the camera sees or the profile declares stands there. ``place_target`` has the measuring device put the target marker on the next
one (a person on hardware) and moves the arm out of the camera's way;
``record_trial`` has the device measure where the tool and the target's centre
really are (the laser spot on millimetre paper) and appends the trial.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from armtree import Param
from armtree.api.rig import needed
from armtree.api.skill.actions import Look, Move, SkillFailure, fmt
from armtree.api.skill.arm import ArmSkill
from armtree.api.skill.base import Procedure, Skill
from armtree.api.skill.eye import eye_of
from armtree.api.skill.sightline import joints_out_of_view, shadow
from armtree.maths.perception.frames import EYE_IN_HAND

from .behaviours import PROGRESS, Measure, _half_view, _list
from .occupied import blocker, declared_keep_outs, free, seen_keep_outs
from .poses import in_view, reachable_mask

#: Fraction of the half image a target and the tool's marker over it may use.
TARGET_MARGIN = 0.6
#: How far a target stays from the markers seen on the table (each on top of an object).
KEEP_OUT = Param("keep_out_mm", "float", 80.0, "mm", "least distance from a target's centre to a marker seen on the table", minimum=0.0, maximum=1000.0)  # fmt: skip


class TargetSkill(ArmSkill):
    """A behaviour of experiment 2 that holds the arm and keeps targets off what the camera
    sees on the table."""

    RESOURCES = ("arm",)
    NEEDS = ("arm",)

    def keep_outs(self, sightings: Any) -> list[Any]:
        """The keep-out discs of the markers in ``sightings``, ``keep_out_mm`` round each; the
        target's own marker (``tag``) and the tool's are not obstacles."""
        skip = {self.param("tag")}
        marker = self.workcell.tool_marker
        if marker is not None:
            skip.add(marker.tag)
        return seen_keep_outs(sightings, skip, float(self.param("keep_out_mm")))


class PlanTargets(TargetSkill):
    """Random table points (mm) over which the tool can hover where the camera sees it, clear
    of what stands on the table.

    With a fixed camera the arm first moves where its links hide least of the table
    (:func:`~armtree.api.skill.sightline.out_of_view`) and the camera takes an
    overview: no target is drawn within ``keep_out_mm`` of a marker it sees (each on
    top of an object; the target's and the tool's own excepted), nor of a table point
    the arm still hides. The profile's ``obstacles`` are kept out of as well.
    """

    PARAMS = (
        Param("count", "int", 30, "", "targets", minimum=1, maximum=1000),
        Param("hover_mm", "float", 40.0, "mm", "tool height above a target", minimum=0.0, maximum=1000.0),
        Param("margin_mm", "float", 15.0, "mm", "room kept around a target within the workspace", minimum=0.0, maximum=200.0),
        Param("tag", "str", "target", "", "tag role of the target marker (not an obstacle)", kind="tag_role"),
        KEEP_OUT,
        Param("spare", "int", 10, "", "further points drawn for targets found occupied when placed", minimum=0, maximum=1000),
        Param("seed", "int", 0, "", "random targets", minimum=0, maximum=2**31),
        Param("targets", "any", None, "mm", "output: table points", io="out"),
        Param("spares", "any", None, "mm", "output: the spare table points", io="out"),
        *ArmSkill.COMMON,
    )  # fmt: skip

    def procedure(self) -> Procedure:
        rig = self.rig
        points = self._candidates()
        keep = declared_keep_outs(getattr(getattr(rig.planner, "checker", None), "scene", None))
        fixed = rig.camera is not None and rig.camera.mount != EYE_IN_HAND
        if fixed and rig.tracker is not None:
            overview = yield from self._overview(points)
            points = points[overview]
        points = points[free(points, keep)]
        if len(points) < self.param("count"):
            raise SkillFailure(
                f"{self.name}: only {len(points)} table points are reachable "
                f"{float(self.param('hover_mm')):g} mm over, in view and clear of what is on "
                f"the table; {self.param('count')} wanted (clear the table or ask for fewer)"
            )
        rng = np.random.default_rng(self.param("seed") + 1)
        count = self.param("count")
        drawn = min(len(points), count + self.param("spare"))
        chosen = points[rng.choice(len(points), drawn, replace=False)]
        self.output("spares", [_list(p) for p in chosen[count:]])
        chosen = chosen[:count]
        self.output("targets", [_list(p) for p in chosen])
        self.feedback_message = f"{len(chosen)} targets"
        return len(chosen)

    def _candidates(self) -> np.ndarray:
        """Table points the tool reaches ``hover_mm`` over (with room around) and, with a
        fixed camera, where the target and the tool's marker over it are well in view."""
        rig = self.rig
        model = needed(rig.arm, "arm").model
        table = self.workcell.need("table_z_mm", self.name)
        hover, margin = float(self.param("hover_mm")), float(self.param("margin_mm"))
        marker = self.workcell.tool_marker
        lift = np.array([0.0, 0.0, hover + (marker.offset_mm[2] if marker is not None else 0.0)])
        view = eye_of(rig).last
        half = view.half_view if view is not None else _half_view(rig)
        rng = np.random.default_rng(self.param("seed"))
        q = rng.uniform(model.lower, model.upper, (20000, model.dof))
        q = q[model.within_limits(q)]
        points = model.position(q)
        points[:, 2] = float(table)
        ring = [
            np.array([margin * np.cos(a), margin * np.sin(a), 0.0])
            for a in np.linspace(0, 2 * np.pi, 8, endpoint=False)
        ]
        ok = reachable_mask(model, points + [0.0, 0.0, hover])
        for d in ring:
            ok &= reachable_mask(model, points + d + [0.0, 0.0, hover])
        if rig.camera is not None and rig.camera.mount != EYE_IN_HAND:
            # the middle of the image: near its edges the arm's own links may hide the marker
            ok &= in_view(rig.camera.extrinsics, half, points + lift, TARGET_MARGIN)
            ok &= in_view(rig.camera.extrinsics, half, points, TARGET_MARGIN)
        return points[ok]

    def _overview(self, points: np.ndarray) -> Procedure:
        """Boolean per point: clear of the markers the camera sees and of what the arm hides,
        looked at with the arm where it hides least of ``points``."""
        rig = self.rig
        if len(points):
            sample = points[:: max(1, len(points) // 200)]
            away = joints_out_of_view(self, sample)
            if away is not None:
                yield Move(rig, joints=away, speed=self.speed(), label="out of the camera's way")
        sightings = yield Look(rig, self.clock, frames=3, settle=self.settle(), average=True)
        radius = float(self.param("keep_out_mm"))
        keep = self.keep_outs(sightings)
        ok = free(points, keep)
        hidden = shadow(self)
        for k in range(0, len(hidden), 256):
            gap = np.linalg.norm(points[:, None, :2] - hidden[None, k : k + 256, :2], axis=2)
            ok &= np.all(gap >= radius, axis=1)
        self.feedback_message = (
            f"{len(keep)} markers seen on the table, {len(hidden)} points hidden"
        )
        return ok


class PlaceTarget(TargetSkill):
    """Have the next target placed (the measuring device: a person, or the simulation), with the
    arm waiting out of the camera's way: with a fixed camera and a survey, where its links do not
    hide the target (:func:`~armtree.api.skill.sightline.joints_out_of_view`), else at ``park``."""

    PARAMS = (
        Param("targets", "any", None, "mm", "in/out: plan_targets' targets (one found occupied is replaced by a spare)", io="inout"),
        Param("spares", "any", None, "mm", "in/out: plan_targets' spares", io="inout"),
        KEEP_OUT,
        Param("tag", "str", "target", doc="tag role of the target marker", kind="tag_role"),
        Param("park", "str", "home", doc="where the arm waits while the target is placed (without a fixed camera's survey)", kind="place"),
        Param("index", "any", None, "", "in/out: the trial's number (0 first)", io="inout"),
        PROGRESS,
        Param("reset", "any", None, "", "output: set to None (the servo's error of the last trial)", io="out"),
        Param("reset_failure", "any", None, "", "output: set to '' (the servo's failure of the last trial)", io="out"),
        *ArmSkill.COMMON,
    )  # fmt: skip

    def procedure(self) -> Procedure:
        rig = self.rig
        targets = self.param("targets") or []
        index = self.param("index") or 0
        if index >= len(targets):
            raise SkillFailure(f"{self.name}: all {len(targets)} targets done")
        if getattr(rig, "reference", None) is None:
            raise SkillFailure(f"{self.name}: this rig has no measuring device to place the target")
        self.output(
            "progress", {"done": index, "total": len(targets), "what": f"target {index + 1}"}
        )
        self.output("reset", None)
        self.output("reset_failure", "")
        self._note = ""
        away = self._out_of_view(np.asarray(targets[index], dtype=float))
        if away is None:
            park = self.point(self.param("park"), self.name)
            yield Move(rig, park, speed=self.speed(), label="wait aside")
        else:
            yield Move(rig, joints=away, speed=self.speed(), label="wait aside")
        if away is not None and rig.tracker is not None:
            # something may have come to stand there since the targets were drawn
            was = targets[index]
            targets = yield from self._still_free(list(targets), index)
            if targets[index] != was:
                away = self._out_of_view(np.asarray(targets[index], dtype=float))
                if away is not None:
                    yield Move(rig, joints=away, speed=self.speed(), label="wait aside")
        marker_id = rig.tags[self.param("tag")].ids[0]
        yield Measure(lambda: rig.reference.place_marker(marker_id, np.asarray(targets[index])[:2]))
        self.output("index", index)
        if self._note:
            self.feedback_message = self._note
        return index

    def _still_free(self, targets: list[Any], index: int) -> Procedure:
        """``targets`` with target ``index`` replaced by the first spare clear of what the camera
        sees now, when something stands on it (a Duckybot parked there since); unchanged else."""
        sightings = yield Look(self.rig, self.clock, frames=3, settle=self.settle(), average=True)
        keep = self.keep_outs(sightings)
        if free(np.asarray(targets[index], dtype=float), keep)[0]:
            return targets
        spares = list(self.param("spares") or [])
        for k, spare in enumerate(spares):
            if free(np.asarray(spare, dtype=float), keep)[0]:
                was = targets[index]
                targets[index] = spare
                self.output("targets", targets)
                self.output("spares", spares[:k] + spares[k + 1 :])
                self._note = (
                    f"target {index + 1} at {fmt(np.asarray(was))} is under {blocker(was, keep)}: "
                    f"placed at {fmt(np.asarray(spare))} instead"
                )
                return targets
        raise SkillFailure(
            f"{self.name}: target {index + 1} at {fmt(np.asarray(targets[index]))} is under "
            f"{blocker(targets[index], keep)} and no spare target is clear"
        )

    def _out_of_view(self, targets: np.ndarray) -> np.ndarray | None:
        """With a fixed camera, the joints of the survey pose whose links hide the target
        (and least of the view) from it; None otherwise (the arm waits at ``park``)."""
        rig = self.rig
        if rig.camera is None or rig.camera.mount == EYE_IN_HAND or not len(targets):
            return None
        return joints_out_of_view(self, targets.reshape(-1, 3))


class RecordTrial(Skill):
    """Measure (the measuring device) where the tool and the target's centre are; append
    ``{target, tool, distance_xy, servo_error, iterations}`` to ``trials``."""

    PARAMS = (
        Param("tag", "str", "target", doc="tag role of the target marker", kind="tag_role"),
        Param("index", "any", None, "", "in/out: the trial's number, advanced by one", io="inout"),
        Param("servo_error", "any", None, "mm", "visual_servo's last measured error"),
        Param("iterations", "any", None, "", "visual_servo's corrections"),
        Param("failure", "any", "", "", "visual_servo's failure, '' when it succeeded"),
        Param("trials", "any", None, "", "in/out: the trials so far", io="inout"),
    )  # fmt: skip
    NEEDS = ()

    def procedure(self) -> Procedure:
        rig = self.rig
        marker_id = rig.tags[self.param("tag")].ids[0]
        tool = yield Measure(rig.reference.tool_position)
        target = yield Measure(lambda: rig.reference.marker_position(marker_id))
        trials: list[dict[str, Any]] = list(self.param("trials") or [])
        error = self.param("servo_error")
        trials.append(
            {
                "target": _list(target),
                "tool": _list(tool),
                "distance_xy": round(
                    float(np.linalg.norm(np.asarray(tool)[:2] - np.asarray(target)[:2])), 4
                ),
                "servo_error": error,
                "iterations": self.param("iterations"),
                "failure": self.param("failure") or "",
            }
        )
        self.output("trials", trials)
        self.output("index", (self.param("index") or 0) + 1)
        self.feedback_message = f"trial {len(trials)}: {trials[-1]['distance_xy']:.2f} mm"
        return len(trials)


__all__ = ["PlaceTarget", "PlanTargets", "RecordTrial"]
