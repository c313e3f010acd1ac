"""Whether the arm's links stand between a fixed camera and a point (mm, base frame).

An eye-to-hand camera loses a marker when a link box of the arm's kinematic model
(the volumes collision checking uses) crosses the line of sight from the camera's
centre to the marker. The boxes are grown by a margin so that a marker (not a
point) and the model's approximations stay in view. Only the arm's own model and
the camera's believed pose are used, never the simulator.
"""

from __future__ import annotations

import numpy as np

from armtree.api.rig import needed
from armtree.errors import PlanningError, Unreachable
from armtree.maths.motion.kinematics import KinematicModel

from .arm import ArmSkill, camera_over
from .eye import eye_of
from .reach import reachable
from .survey import survey_points

#: Growth of each link box (mm): half a marker's diagonal and some slack.
SIGHT_MARGIN_MM = 20.0


def segment_hits_boxes(
    start: np.ndarray,
    end: np.ndarray,
    poses: np.ndarray,
    half: np.ndarray,
) -> np.ndarray:
    """Boolean ``(..., B)``: the segment ``start`` -> ``end`` (mm) crosses each oriented box.

    ``poses`` ``(..., B, 4, 4)`` are the box centres' poses, ``half`` ``(B, 3)`` their
    half sizes (mm); ``start`` and ``end`` broadcast against the boxes (``end`` of
    shape ``(N, 1, 3)`` gives ``(N, B)``). Slab test in each box's frame; exact for boxes.
    """
    start = np.asarray(start, dtype=float)
    end = np.asarray(end, dtype=float)
    rot = poses[..., :3, :3]
    centre = poses[..., :3, 3]
    # the segment's ends in each box's frame
    a = np.einsum("...ji,...j->...i", rot, start - centre)
    b = np.einsum("...ji,...j->...i", rot, end - centre)
    d = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-half - a) / d
        t2 = (half - a) / d
    flat = np.abs(d) < 1e-12
    inside = np.abs(a) <= half
    lo = np.where(flat, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2))
    hi = np.where(flat, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2))
    enter = np.maximum(lo.max(axis=-1), 0.0)
    leave = np.minimum(hi.min(axis=-1), 1.0)
    return enter <= leave


def hides(
    model: KinematicModel,
    q: np.ndarray,
    camera: np.ndarray,
    point: np.ndarray,
    margin: float = SIGHT_MARGIN_MM,
) -> np.ndarray:
    """Boolean ``(...)``: with the joints ``q`` ``(..., n)`` some link box, grown by
    ``margin`` mm, crosses the line from the ``camera`` position to ``point`` (mm).

    ``point`` broadcasts against the joints' leading shape with one more axis for
    the boxes (points ``(N, 1, 1, 3)`` and joints ``(K, n)`` give ``(N, K)``). An arm
    without link boxes hides nothing (the caller falls back on distances).
    """
    q = np.asarray(q, dtype=float)
    point = np.asarray(point, dtype=float)
    if not model.boxes:
        return np.zeros(np.broadcast_shapes(q.shape[:-1], point.shape[:-2]), dtype=bool)
    half = 0.5 * model.box_sizes() + float(margin)
    hit = segment_hits_boxes(camera, point, model.box_poses(q), half)
    return np.any(hit, axis=-1)


def out_of_view(skill: ArmSkill, points: np.ndarray) -> np.ndarray | None:
    """Eye-to-hand: the reachable survey pose (tool position, mm) on the sweep from where
    the arm is where its links hide fewest of ``points`` (mm, ``(3,)`` or ``(N, 3)``) from
    the camera, with the joints a move there takes (the solution nearest to the arm's);
    among equals the farthest from the points. None without a survey or when no survey
    pose is reachable.

    The links are the arm model's boxes (:func:`hides`). An arm model without boxes
    hides nothing, so the pose farthest from the points is taken. :func:`joints_out_of_view`
    looks further: the whole survey, every inverse-kinematics solution, and how much of
    the camera's view each hides.
    """
    best = _out_of_view(skill, points, every_solution=False)
    return None if best is None else best[0]


def joints_out_of_view(skill: ArmSkill, points: np.ndarray) -> np.ndarray | None:
    """Eye-to-hand: the joints (degrees / mm) of a survey pose, over the whole survey and
    every inverse-kinematics solution the rig's planner reaches from where the arm is, whose
    links hide fewest of ``points`` (mm) from the camera; among equals the one that hides
    least of the camera's view of the table (near a link a marker may sit in its cast
    shadow or at its edge, where the camera cannot read it), then the farthest from the
    points. None without a survey or when nothing is reachable."""
    best = _out_of_view(skill, points, every_solution=True)
    return None if best is None else best[1]


def _out_of_view(
    skill: ArmSkill, points: np.ndarray, every_solution: bool
) -> tuple[np.ndarray, np.ndarray] | None:
    cell = skill.workcell
    if cell.survey is None or cell.table_z_mm is None:
        return None
    model = needed(skill.rig.arm, "arm").model
    here = needed(skill.rig.arm, "arm").pose()[:3, 3]
    near = np.asarray(needed(skill.rig.arm, "arm").joints(), dtype=float)
    poses, joints = [], []
    # two legs: a ring sweep from here runs to one end of its range first, then to the other
    legs = 2 if every_solution else 1
    for p in survey_points(cell.survey, float(cell.table_z_mm), here, legs):
        tool = camera_over(skill, p, cell.look_height_mm)
        if not reachable(model, tool):
            continue
        if every_solution:
            sols = model.ik_all(tool)
            sols = sols[np.all(np.isfinite(sols), axis=-1)]
        else:
            sols = model.ik(tool, near=near)[None]
        poses += [tool] * len(sols)
        joints += list(sols)
    if not poses:
        return None
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    q = np.array(joints)
    hidden = _hidden(skill, q, points)
    in_view = _hidden(skill, q, view_grid(skill, VIEW_SPACING_MM)) if every_solution else hidden * 0
    centre = points.mean(axis=0)
    order = sorted(
        range(len(poses)),
        key=lambda k: (
            int(hidden[k]),
            int(in_view[k]),
            -float(np.linalg.norm(poses[k][:2] - centre[:2])),
        ),
    )
    planner = skill.rig.planner if every_solution else None
    for k in order:
        if planner is not None:
            # another solution may lie across a singularity or an obstacle from here
            try:
                planner.plan(near, q[k])
            except (PlanningError, Unreachable):
                continue
        return poses[k], q[k]
    return None


#: Spacing (mm) of the table points by which :func:`out_of_view` weighs how much of the
#: camera's view a pose hides.
VIEW_SPACING_MM = 40.0


def _hidden(skill: ArmSkill, joints: np.ndarray, points: np.ndarray) -> np.ndarray:
    """How many of ``points`` (mm) the links hide from the camera at each of ``joints``."""
    model = needed(skill.rig.arm, "arm").model
    camera = np.asarray(needed(skill.rig.camera, "camera").extrinsics, dtype=float)[:3, 3]
    hidden = np.zeros(len(joints), dtype=int)
    for k in range(0, len(points), 64):
        hidden += np.sum(hides(model, joints, camera, points[k : k + 64, None, None, :]), axis=0)
    return hidden


def view_grid(skill: ArmSkill, spacing: float) -> np.ndarray:
    """Eye-to-hand: table points (mm, ``(N, 3)``, ``spacing`` apart) covering what the fixed
    camera sees of the table; empty without a table or a camera looking down."""
    rig, cell = skill.rig, skill.workcell
    if cell.table_z_mm is None:
        return np.zeros((0, 3))
    table = float(cell.table_z_mm)
    camera = np.asarray(needed(rig.camera, "camera").extrinsics, dtype=float)
    view = eye_of(rig).last
    hx, hy = view.half_view if view is not None else (0.6, 0.45)
    corners = []
    for sx, sy in ((-1, -1), (-1, 1), (1, -1), (1, 1)):
        ray = camera[:3, :3] @ np.array([sx * hx, sy * hy, 1.0])
        if ray[2] >= -1e-9:
            return np.zeros((0, 3))  # not looking down at the table
        corners.append(camera[:3, 3] + ray * ((table - camera[2, 3]) / ray[2]))
    lo, hi = np.min(corners, axis=0), np.max(corners, axis=0)
    xs = np.arange(lo[0], hi[0] + spacing, spacing)
    ys = np.arange(lo[1], hi[1] + spacing, spacing)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    return np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, table)])


def shadow(skill: ArmSkill, spacing: float = 10.0) -> np.ndarray:
    """Eye-to-hand: the table points (mm, ``(N, 3)``, ``spacing`` apart) in the camera's
    view that the arm's links hide from it where the arm is now; empty without a table."""
    rig = skill.rig
    grid = view_grid(skill, spacing)
    model = needed(rig.arm, "arm").model
    if not len(grid) or not model.boxes:
        return np.zeros((0, 3))
    q = np.asarray(needed(rig.arm, "arm").joints(), dtype=float)
    return grid[
        hides(
            model, q, np.asarray(needed(rig.camera, "camera").extrinsics)[:3, 3], grid[:, None, :]
        )
    ]


__all__ = [
    "SIGHT_MARGIN_MM",
    "hides",
    "joints_out_of_view",
    "out_of_view",
    "segment_hits_boxes",
    "shadow",
    "view_grid",
]
