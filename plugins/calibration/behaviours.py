"""The behaviours calibration trees are made of: plan poses, visit them, fit, write.

``plan_poses`` chooses where the tool goes (Durovic 2017's three positions, well-spread
poses, a grid of reference points, views of a marker); ``visit_poses`` moves there
one pose after another, reads the camera once the arm is still (the marker's pose
in the camera frame, averaged over frames) and asks the rig's measuring device
(``rig.reference``) where the tool or a marker really is when the calibration
needs the truth; ``fit_calibration`` fits (:mod:`.fits`) and ``write_calibration``
writes the calibration file a profile includes and a residual plot. Observations
travel on the blackboard as plain lists (mm, radians), one mapping per pose.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from armtree import Param, PlanningError, Unreachable
from armtree.api.rig import Rig, needed
from armtree.api.skill.actions import Action, Look, Move, SkillFailure, State, fmt
from armtree.api.skill.arm import ArmSkill, camera_over
from armtree.api.skill.base import Procedure, Skill
from armtree.api.skill.eye import eye_of
from armtree.maths.perception.frames import EYE_IN_HAND

from . import fits, slips
from .occupied import free, seen_keep_outs
from .poses import in_view, reachable_mask, spread, square_grid, workspace_samples

PLANS = ("three_positions", "spread", "grid", "joints", "views")
#: Least distance (mm, x-y) of a pose's tool from a marker seen on the table below it.
KEEP_OUT_MM = 80.0
#: Least height (mm) of a pose's tool above the top of something seen on the table.
POSE_CLEARANCE_MM = 30.0
KINDS = ("hand_eye", "correction", "camera_offset", "kinematics")
#: The progress output of the behaviours that take many steps (a progress bar shows it).
PROGRESS = Param("progress", "any", None, "", "output: {done, total, what}", io="out")


class Observe(Action):
    """Read ``frames`` fresh frames after ``settle`` s and average the camera-frame pose of
    the marker of ``role`` (its first id seen); the result is ``(tvec, rvec, camera)`` or
    None when no frame saw it. No frame within ``timeout`` s fails the step."""

    def __init__(self, rig: Rig, clock: Any, role: str, frames: int, settle: float) -> None:
        self.rig, self.clock, self.role = rig, clock, role
        self.frames, self.settle, self.timeout = frames, settle, 3.0
        self._t0 = 0.0
        self._used = -1
        self._tv: list[np.ndarray] = []
        self._rv: list[np.ndarray] = []
        self._count = 0
        self._camera: np.ndarray | None = None

    def describe(self) -> str:
        """What this step does, for messages."""
        return f"look for the {self.role} marker"

    def start(self) -> None:
        self._t0 = self.clock.now() + self.settle
        self._tv, self._rv, self._count, self._used = [], [], 0, -1

    def poll(self) -> State:
        view = eye_of(self.rig).newest()
        if view is not None and view.timestamp >= self._t0 - 1e-9 and view.index != self._used:
            self._used = view.index
            self._count += 1
            self._camera = view.camera
            for s in view.of(self.role):
                if s.detection.tvec is not None:
                    self._tv.append(np.asarray(s.detection.tvec, dtype=float).reshape(3))
                    rv = s.detection.rvec
                    self._rv.append(
                        np.zeros(3) if rv is None else np.asarray(rv, dtype=float).reshape(3)
                    )
                    break
            if self._count >= self.frames:
                self.result = None
                if self._tv:
                    self.result = (
                        np.mean(self._tv, axis=0),
                        np.mean(self._rv, axis=0),
                        self._camera,
                    )
                return State.DONE
        elif self.clock.now() > self._t0 + self.timeout:
            return self.fail(f"the camera gave no frame for {self.timeout:g} s")
        return State.RUNNING


class Measure(Action):
    """Wait for a :class:`~armtree.api.measuring.Measurement` of the rig's measuring device."""

    def __init__(self, start: Any) -> None:
        self._start = start
        self.handle: Any = None

    def describe(self) -> str:
        """What this step does, for messages."""
        return f"measure the {getattr(self.handle, 'what', 'reference')} (measuring device)"

    def start(self) -> None:
        self.handle = self._start()

    def poll(self) -> State:
        if not self.handle.done:
            return State.RUNNING
        if self.handle.error:
            return self.fail(f"the measuring device: {self.handle.error}")
        self.result = self.handle.value
        return State.DONE


def _list(a: Any) -> Any:
    return None if a is None else np.round(np.asarray(a, dtype=float), 6).tolist()


class PlanPoses(ArmSkill):
    """Choose the tool positions a calibration visits (mm, base frame), reachable and, with a
    fixed camera, where it sees the tool's marker."""

    PARAMS = (
        Param("plan", "str", "spread", doc="three_positions, spread, grid, joints or views", choices=PLANS),
        Param("count", "int", 15, "", "poses (spread, joints, views)", minimum=3, maximum=1000),
        Param("grid", "int", 10, "", "points along each side of the grid", minimum=2, maximum=100),
        Param("step_mm", "float", 40.0, "mm", "three_positions: the moves along x, then y", exclusive_minimum=0.0, maximum=1000.0),
        Param("height_mm", "float", None, "mm", "tool height above the table; spread: the lowest (default: the profile's clearance)", minimum=-1000.0, maximum=1000.0),
        Param("tag", "str", "", "", "views: the tag role of the still marker", kind="tag_role"),
        Param("seed", "int", 0, "", "random poses", minimum=0, maximum=2**31),
        Param("poses", "any", None, "mm", "output: the tool positions", io="out"),
        *ArmSkill.COMMON,
    )  # fmt: skip
    NEEDS = ("arm",)

    def procedure(self) -> Procedure:
        plan = self.param("plan")
        rng = np.random.default_rng(self.param("seed"))
        if plan == "views":
            points = yield from self._views(rng)
        elif plan == "joints":
            points = yield from self._joints(rng)
        else:
            points = self._plan(plan, rng)
        self.output("poses", [_list(p) for p in points])
        self.feedback_message = f"{len(points)} poses ({plan})"
        return len(points)
        yield  # pragma: no cover

    def _height(self) -> float:
        cell = self.workcell
        table = cell.table_z_mm if cell.table_z_mm is not None else 0.0
        h = self.param("height_mm")
        if h is None:
            clearance = cell.clearance_z_mm if cell.clearance_z_mm is not None else table + 20.0
            return float(max(clearance, table + 20.0))
        return float(table + h)

    def _usable(self) -> Any:
        rig = self.rig
        model = needed(rig.arm, "arm").model
        marker = self.workcell.tool_marker
        lift = np.array([0.0, 0.0, marker.offset_mm[2] if marker is not None else 0.0])
        fixed = rig.camera is not None and rig.camera.mount != EYE_IN_HAND
        view = eye_of(rig).last if rig.camera is not None else None
        half = view.half_view if view is not None else _half_view(rig)

        def usable(points: np.ndarray) -> np.ndarray:
            ok = reachable_mask(model, points)
            if fixed:
                ok &= in_view(needed(rig.camera, "camera").extrinsics, half, points + lift)
            return ok

        return usable

    def _plan(self, plan: str, rng: np.random.Generator) -> list[np.ndarray]:
        model = needed(self.rig.arm, "arm").model
        usable = self._usable()
        height = self._height()
        if plan == "grid":
            try:
                grid = square_grid(model, height, self.param("grid"), usable)
            except ValueError as exc:
                raise SkillFailure(f"{self.name}: {exc}") from None
            return list(grid)
        if plan == "three_positions":
            return self._three(usable, height)
        low = self.workcell.clearance_z_mm if self.param("height_mm") is None else height
        points = workspace_samples(model, rng, 6000, min_z=low)
        points = points[usable(points)]
        if len(points) < self.param("count"):
            raise SkillFailure(
                f"{self.name}: only {len(points)} reachable poses where the camera sees the tool"
            )
        return list(spread(points, self.param("count"), rng))

    def _joints(self, rng: np.random.Generator) -> Procedure:
        """Showers 2016's validation poses: random joints within the limits, spread out, where the
        arm collides with nothing the planner knows (the profile's obstacles) and, with a
        fixed camera, the tool stays :data:`POSE_CLEARANCE_MM` above what it sees on the table."""
        rig = self.rig
        model = needed(rig.arm, "arm").model
        q = rng.uniform(model.lower, model.upper, (6000, model.dof))
        q = q[model.within_limits(q)]
        checker = getattr(rig.planner, "checker", None)
        if checker is not None:
            q = q[np.asarray(checker.valid(q), dtype=bool)]
        points = model.position(q)
        low = self.workcell.clearance_z_mm
        if low is not None:
            points = points[points[:, 2] >= low]
        if rig.camera is not None and rig.camera.mount != EYE_IN_HAND and rig.tracker is not None:
            sightings = yield Look(rig, self.clock, frames=3, settle=self.settle(), average=True)
            marker = self.workcell.tool_marker
            skip = {marker.tag} if marker is not None else set()
            keep = seen_keep_outs(sightings, skip, KEEP_OUT_MM)
            points = points[free(points, keep, POSE_CLEARANCE_MM)]
        count = self.param("count")
        chosen = self._planned(spread(points, 3 * count, rng), count)
        if len(chosen) < count:
            raise SkillFailure(
                f"{self.name}: only {len(chosen)} collision-free poses within the joint limits "
                f"the planner finds a path to; {count} wanted"
            )
        return chosen

    def _planned(self, points: np.ndarray, count: int) -> list[np.ndarray]:
        """Up to ``count`` of ``points`` in order, each one the rig's planner finds a path to
        from the one before (from where the arm is for the first); all without a planner."""
        planner = self.rig.planner
        if planner is None:
            return list(points[:count])
        start = np.asarray(needed(self.rig.arm, "arm").joints(), dtype=float)
        out: list[np.ndarray] = []
        for point in points:
            try:
                path = planner.plan_to(start, point)
            except (PlanningError, Unreachable):
                continue
            out.append(point)
            start = np.asarray(path[-1], dtype=float)
            if len(out) == count:
                break
        return out

    def _three(self, usable: Any, height: float) -> list[np.ndarray]:
        """Durovic 2017, steps 1-5: a point on the base x axis, moved by a along x, then b along y."""
        step = float(self.param("step_mm"))
        best = None
        for x0 in np.arange(20.0, 1000.0, 2.0):
            pts = np.array([[x0, 0.0, height], [x0 + step, 0.0, height], [x0 + step, step, height]])
            if np.all(usable(pts)):
                best = pts
                pts_neg = pts.copy()
                pts_neg[2, 1] = -step
                break
        if best is None:
            for sign in (-1.0,):
                for x0 in np.arange(20.0, 1000.0, 2.0):
                    pts = np.array(
                        [
                            [x0, 0.0, height],
                            [x0 + step, 0.0, height],
                            [x0 + step, sign * step, height],
                        ]
                    )
                    if np.all(usable(pts)):
                        best = pts
                        break
        if best is None:
            raise SkillFailure(
                f"{self.name}: no three positions {step:g} mm apart along x then y at z = "
                f"{height:g} mm are reachable and in view: make step_mm smaller"
            )
        return list(best)

    def _views(self, rng: np.random.Generator) -> Procedure:
        """Camera poses around the still marker ``tag``, looked for from where the arm is."""
        rig, tag = self.rig, self.param("tag")
        obs = yield Observe(rig, self.clock, tag, 3, self.settle())
        if obs is None:
            raise SkillFailure(
                f"{self.name}: the {tag!r} marker is not in view from the tool at "
                f"{fmt(needed(rig.arm, 'arm').pose()[:3, 3])}: bring the camera over it first"
            )
        tvec, _, camera = obs
        centre = (camera @ np.append(tvec, 1.0))[:3]
        height = self.workcell.look_height_mm
        out = []
        for k in range(self.param("count")):
            angle = 2 * np.pi * (k / self.param("count")) + rng.uniform(-0.2, 0.2)
            r = rng.uniform(5.0, 20.0)
            point = centre + np.array([r * np.cos(angle), r * np.sin(angle), 0.0])
            try:
                out.append(camera_over(self, point, height * rng.uniform(0.8, 1.0)))
            except SkillFailure:
                continue
        if len(out) < 3:
            raise SkillFailure(f"{self.name}: fewer than 3 reachable views of the {tag!r} marker")
        return out


def _half_view(rig: Rig) -> tuple[float, float]:
    k = getattr(rig.camera, "camera_matrix", None)
    w, h = getattr(rig.camera, "width", 640), getattr(rig.camera, "height", 480)
    if k is None:
        return (0.4, 0.3)
    return (0.5 * w / float(k[0][0]), 0.5 * h / float(k[1][1]))


class VisitPoses(ArmSkill):
    """Visit each of ``poses``: move (the profile's arm correction left out), let the arm
    settle, read the camera for ``look_for`` and ask the measuring device for the tool's
    true position (``measure_tool``); at the end, the true position of the ``touch``
    marker. Poses the arm refuses are recorded as not reached.

    With ``slip_mm`` above 0 the camera watches for missed steps the arm cannot report
    (:mod:`.slips`): ``check: joints`` compares, at each pose, the camera's measurement
    of the tool's marker with where the joints put the tool (a calibrated fixed
    camera); ``check: reference`` looks at the first pose again every ``check_every``
    poses, where the camera must see the marker where it saw it then (any camera,
    calibrated or not). Either way the arm homes on its own reference and measures
    again what the slip spoiled; the step fails with the reason when homing does not
    set it right (``redo`` times at most, or homing changes nothing). The records say
    how often each pose was measured again.
    """

    PARAMS = (
        Param("poses", "any", doc="tool positions (mm)"),
        Param("look_for", "str", "", "", "tag role to read at each pose ('' for none)", kind="tag_role"),
        Param("tool_marker", "bool", False, "", "read the tool's marker (the profile's workcell.tool_marker)"),
        Param("measure_tool", "bool", False, "", "ask the measuring device where the tool is"),
        Param("touch", "str", "", "", "tag role whose marker the measuring device locates at the end", kind="tag_role"),
        Param("frames", "int", 5, "", "frames averaged per pose", minimum=1, maximum=100),
        Param("slip_mm", "float", 0.0, "mm", "missed steps: home and measure again where the camera finds the tool moved by more (0: no check)", minimum=0.0, maximum=100.0),
        Param("check", "str", "joints", doc="joints (each pose against the joints, calibrated fixed camera) or reference (the first pose seen again)", choices=slips.CHECKS),
        Param("check_every", "int", 5, "", "check reference: poses between two looks at the first pose", minimum=1, maximum=1000),
        Param("redo", "int", 5, "", "homings to set one slip right before the step fails", minimum=1, maximum=20),
        Param("observations", "any", None, "", "output: one mapping per pose", io="out"),
        PROGRESS,
        *ArmSkill.COMMON,
    )  # fmt: skip
    RESOURCES = ("arm",)
    NEEDS = ("arm",)

    def procedure(self) -> Procedure:
        rig = self.rig
        poses = [np.asarray(p, dtype=float) for p in (self.param("poses") or [])]
        slip, check = float(self.param("slip_mm")), self.param("check")
        role = self._role(slip, check)
        watch = slips.SlipWatch(self, role, slip, self.param("redo"))
        if slip and check == "reference":
            out = yield from watch.by_reference(poses, self.param("check_every"))
        else:
            out = []
            for k, pose in enumerate(poses):
                out.append((yield from watch.by_joints(k, pose, len(poses))))
        touched = None
        touch = self.param("touch")
        if touch:
            ids = rig.tags[touch].ids
            touched = yield Measure(lambda: rig.reference.marker_position(ids[0]))
        self.report_progress(len(poses), len(poses), "done")
        self.output(
            "observations",
            {
                "poses": out,
                "touched": _list(touched),
                "device": getattr(rig.reference, "description", ""),
                "slips": watch.summary(),
            },
        )
        self.feedback_message = f"{sum(r.get('seen', False) for r in out)} of {len(out)} poses seen"
        return len(out)

    def _role(self, slip: float, check: str) -> str:
        """The tag role to look for at each pose; SkillFailure when the rig cannot do what
        the parameters ask."""
        rig = self.rig
        role = self.param("look_for")
        if self.param("tool_marker"):
            marker = self.workcell.tool_marker
            if marker is None:
                raise SkillFailure(
                    f"{self.name}: needs workcell.tool_marker in the profile (the tool's marker)"
                )
            role = marker.tag
        if role and (rig.camera is None or rig.tracker is None):
            raise SkillFailure(f"{self.name}: this rig has no camera to look for {role!r} with")
        if slip and not role:
            raise SkillFailure(f"{self.name}: slip_mm needs a marker to look at (look_for)")
        fixed_marker = (
            self.param("tool_marker") and needed(rig.camera, "camera").mount != EYE_IN_HAND
        )
        if slip and check == "joints" and not fixed_marker:
            raise SkillFailure(
                f"{self.name}: check joints needs tool_marker and a fixed camera; use reference"
            )
        if slip and not (fixed_marker or needed(rig.camera, "camera").mount == EYE_IN_HAND):
            raise SkillFailure(
                f"{self.name}: a fixed camera looking at a still marker cannot see the arm slip: "
                "look at the tool's marker (tool_marker) or set slip_mm 0"
            )
        measures = self.param("measure_tool") or self.param("touch")
        if measures and getattr(rig, "reference", None) is None:
            raise SkillFailure(f"{self.name}: this rig has no measuring device (rig.reference)")
        return role

    def report_progress(self, done: int, total: int, what: str) -> None:
        """The progress output: ``done`` of ``total``, doing ``what``."""
        self.output("progress", {"done": done, "total": total, "what": what})

    def visit_pose(
        self, k: int, pose: np.ndarray, role: str, total: int, what: str = "", done: int = -1
    ) -> Procedure:
        """Move to pose ``k`` (``pose``, of ``total``) and look for ``role``: the pose's record.
        ``what`` and ``done`` say what the visit is for and how many poses are done on the
        progress bar (default: pose ``k``, ``k`` done)."""
        rig = self.rig
        self.report_progress(
            k if done < 0 else done, total, what or f"pose {k + 1}/{total} at {fmt(pose)}"
        )
        record: dict[str, Any] = {"commanded": _list(pose), "reached": True, "seen": False}
        try:
            yield Move(rig, pose, speed=self.speed(), label=f"pose {k + 1}", corrected=False)
        except SkillFailure as exc:
            record["reached"], record["why"] = False, str(exc)
            return record
        q = np.asarray(needed(rig.arm, "arm").joints(), dtype=float)
        record["joints"] = _list(q)
        record["tool_pose"] = _list(needed(rig.arm, "arm").model.fk(q))
        if role:
            obs = yield Observe(rig, self.clock, role, self.param("frames"), self.settle())
            if obs is not None:
                tvec, rvec, camera = obs
                record.update(seen=True, tvec=_list(tvec), rvec=_list(rvec), camera=_list(camera))
        if self.param("measure_tool"):
            record["truth"] = _list((yield Measure(rig.reference.tool_position)))
        return record


class FitCalibration(Skill):
    """Fit one calibration from ``observations`` (:mod:`.fits`); FAILURE with the reason and
    the pose to fix when the data cannot calibrate, or when the fit makes held-out error worse."""

    PARAMS = (
        Param("kind", "str", doc="hand_eye, correction, camera_offset or kinematics", choices=KINDS),
        Param("observations", "any", doc="visit_poses' output"),
        Param("methods", "list", [], "", "hand_eye: the methods to try (default: all)"),
        Param("folds", "int", 5, "", "cross-validation folds", minimum=2, maximum=100),
        Param("result", "any", None, "", "output: the fit, for write_calibration", io="out"),
    )  # fmt: skip
    NEEDS = ()

    def procedure(self) -> Procedure:
        try:
            result = fits.fit(
                self.param("kind"),
                self.param("observations") or {},
                self.rig,
                self.param("methods"),
                self.param("folds"),
            )
        except fits.Refused as exc:
            raise SkillFailure(f"{self.name}: {exc}") from None
        self.output("result", result)
        self.feedback_message = result["summary"]
        return result
        yield  # pragma: no cover


class WriteCalibration(Skill):
    """Write a fit's sections into the calibration ``file`` (kept what other calibrations
    wrote) and its residual ``plot`` (PNG)."""

    PARAMS = (
        Param("result", "any", doc="fit_calibration's output"),
        Param("file", "str", "calibration.yaml", doc="the calibration file (YAML)"),
        Param("plot", "str", "", doc="residual plot (PNG); '' for none"),
    )
    NEEDS = ()

    def procedure(self) -> Procedure:
        result = self.param("result")
        if not result:
            raise SkillFailure(f"{self.name}: nothing to write (no fit)")
        fits.write(result, self.param("file"), self.param("plot") or None)
        self.feedback_message = f"wrote {self.param('file')}"
        return self.param("file")
        yield  # pragma: no cover


__all__ = ["FitCalibration", "Measure", "Observe", "PlanPoses", "VisitPoses", "WriteCalibration"]
