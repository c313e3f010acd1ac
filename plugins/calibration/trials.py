"""Behaviours of seed 000's experiment 2: targets placed one after another, the tool servoed
over each, the distance measured from outside.

``plan_targets`` draws table points where the target can lie: the tool reaches
``hover_mm`` above it and, with a fixed camera, the camera sees the tool's marker
there. ``place_target`` has the measuring device put the target marker on the next
one (a person on hardware) and moves the arm out of the camera's way;
``record_trial`` has the device measure where the tool and the target's centre
really are (the laser spot on millimetre paper) and appends the trial.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from armtree import Param
from armtree.plugins.skills.actions import Move, SkillFailure
from armtree.plugins.skills.arm_skill import ArmSkill
from armtree.plugins.skills.base import Procedure, Skill
from armtree.plugins.skills.eye import eye_of

from .behaviours import Measure, _half_view, _list
from .poses import in_view, reachable_mask

#: Fraction of the half image a target and the tool's marker over it may use.
TARGET_MARGIN = 0.6


class PlanTargets(ArmSkill):
    """Random table points (mm) over which the tool can hover where the camera sees it."""

    PARAMS = (
        Param("count", "int", 30, "", "targets", minimum=1, maximum=1000),
        Param("hover_mm", "float", 40.0, "mm", "tool height above a target", minimum=0.0, maximum=1000.0),
        Param("margin_mm", "float", 15.0, "mm", "room kept around a target within the workspace", minimum=0.0, maximum=200.0),
        Param("seed", "int", 0, "", "random targets", minimum=0, maximum=2**31),
        Param("targets", "any", None, "mm", "output: table points", io="out"),
        *ArmSkill.COMMON,
    )  # fmt: skip
    NEEDS = ("arm",)

    def procedure(self) -> Procedure:
        rig = self.rig
        model = rig.arm.model
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
        if rig.camera is not None and rig.camera.mount != "eye_in_hand":
            # the middle of the image: near its edges the arm's own links may hide the marker
            ok &= in_view(rig.camera.extrinsics, half, points + lift, TARGET_MARGIN)
            ok &= in_view(rig.camera.extrinsics, half, points, TARGET_MARGIN)
        points = points[ok]
        if len(points) < self.param("count"):
            raise SkillFailure(
                f"{self.name}: only {len(points)} table points are reachable {hover:g} mm over and in view"
            )
        chosen = points[rng.choice(len(points), self.param("count"), replace=False)]
        self.output("targets", [_list(p) for p in chosen])
        self.feedback_message = f"{len(chosen)} targets"
        return len(chosen)
        yield  # pragma: no cover


class PlaceTarget(ArmSkill):
    """Have the next target placed (the measuring device: a person, or the simulation), with the
    arm waiting out of the camera's way at ``park``."""

    PARAMS = (
        Param("targets", "any", doc="plan_targets' output"),
        Param("tag", "str", "target", doc="tag role of the target marker", kind="tag_role"),
        Param("park", "str", "home", doc="where the arm waits while the target is placed", kind="place"),
        Param("index", "any", None, "", "in/out: the trial's number (0 first)", io="inout"),
        Param("progress", "any", None, "", "output: {done, total, what}", io="out"),
        Param("reset", "any", None, "", "output: set to None (the servo's error of the last trial)", io="out"),
        Param("reset_failure", "any", None, "", "output: set to '' (the servo's failure of the last trial)", io="out"),
        *ArmSkill.COMMON,
    )  # fmt: skip
    RESOURCES = ("arm",)
    NEEDS = ("arm",)

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
        yield Move(
            rig, self.point(self.param("park"), self.name), speed=self.speed(), label="wait aside"
        )
        marker_id = rig.tags[self.param("tag")].ids[0]
        yield Measure(lambda: rig.reference.place_marker(marker_id, np.asarray(targets[index])[:2]))
        self.output("index", index)
        return index


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
