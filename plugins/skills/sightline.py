"""Whether the arm's links stand between a fixed camera and a point (mm, base frame).

An eye-to-hand camera loses a marker when a link box of the arm's kinematic model
(the volumes collision checking uses) crosses the line of sight from the camera's
centre to the marker. The boxes are grown by a margin so that a marker (not a
point) and the model's approximations stay in view. Only the arm's own model and
the camera's believed pose are used, never the simulator.
"""

from __future__ import annotations

import numpy as np

from armtree.maths.motion.kinematics import KinematicModel

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


__all__ = ["SIGHT_MARGIN_MM", "hides", "segment_hits_boxes"]
