"""What a survey shows: the table points whose marker the camera sees whole from some scan pose.

A sweep (``sweep``, ``search_step``) brings an eye-in-hand camera over each point of
the profile's ``workcell.survey`` at ``workcell.look_height_mm`` (lower where the
arm cannot reach that high); an eye-to-hand camera looks from where it stands. A
marker is found only when all of it is in one image, so the region a survey
covers is narrower than the images' union by half a marker's diagonal. These
functions ask the arm's model and the camera's believed pose and intrinsics
(never the simulator), so a profile's survey can be checked against the region
its objects may lie in before anything runs. mm and degrees.
"""

from __future__ import annotations

import math

import numpy as np

from armtree.api.rig import Rig
from armtree.api.skill.arm import tool_under_camera
from armtree.api.skill.survey import survey_points
from armtree.config.workcell import workcell_of
from armtree.errors import ConfigError
from armtree.maths.perception.frames import EYE_IN_HAND, camera_in_base

#: A corner this close to the image's edge (px) may be lost to blur and noise.
EDGE_PX = 3.0


def scan_cameras(rig: Rig, sweeps: int = 2, start: np.ndarray | None = None) -> list[np.ndarray]:
    """Camera poses (4x4, base frame, mm) from which a sweep of ``sweeps`` legs looks.

    Eye-in-hand: one per scan pose of the profile's survey, placed as the sweep
    places them (:func:`~armtree.api.skill.arm.camera_over`), starting
    at the base angle of ``start`` (default: the arm's home). Eye-to-hand: the one
    fixed camera. Needs a built rig (arm model, camera extrinsics); nothing moves.
    """
    camera = rig.camera
    if camera is None:
        raise ConfigError("a scan of the camera's view needs a camera in the profile (camera:)")
    if camera.mount != EYE_IN_HAND:
        return [np.asarray(camera.extrinsics, dtype=float)]
    cell = workcell_of(rig.profile)
    if rig.arm is None:
        raise ConfigError("a scan of an eye-in-hand camera's view needs an arm (arm:)")
    model = rig.arm.model
    here = model.position(model.home) if start is None else np.asarray(start, dtype=float)
    q = np.asarray(model.home, dtype=float)
    survey = cell.need("survey", "a scan of the camera's view")
    table_z = float(cell.need("table_z_mm", "a scan of the camera's view"))
    poses = []
    for point in survey_points(survey, table_z, here, sweeps):
        tool = tool_under_camera(
            model, camera, q, cell.clearance_z_mm, point, float(cell.look_height_mm)
        )
        q = model.ik(tool, near=q)
        poses.append(camera_in_base(camera.mount, camera.extrinsics, model.fk(q)))
    return poses


def seen_whole(
    camera_pose: np.ndarray,
    camera_matrix: np.ndarray,
    image_size: tuple[int, int],
    centres: np.ndarray,
    half_diagonal: float,
) -> np.ndarray:
    """Boolean per marker centre ``(N, 3)`` (mm, base frame, facing up): whether all of the
    marker lies in the image at any yaw, that is every point of the circle of radius
    ``half_diagonal`` around it projects inside ``image_size`` (width, height px) by
    :data:`EDGE_PX`."""
    inv = np.linalg.inv(np.asarray(camera_pose, dtype=float))
    angles = np.linspace(0.0, 2.0 * math.pi, 16, endpoint=False)
    circle = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], 1) * half_diagonal
    rims = np.asarray(centres, dtype=float).reshape(-1, 1, 3) + circle  # (N, 16, 3)
    p = rims @ inv[:3, :3].T + inv[:3, 3]
    z = p[..., 2]
    k = np.asarray(camera_matrix, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = k[0, 0] * p[..., 0] / z + k[0, 2]
        v = k[1, 1] * p[..., 1] / z + k[1, 2]
    w, h = image_size
    inside = (z > 1.0) & (u >= EDGE_PX) & (u <= w - EDGE_PX) & (v >= EDGE_PX) & (v <= h - EDGE_PX)
    return np.all(inside, axis=1)


def unseen(
    rig: Rig,
    points: np.ndarray,
    marker_mm: float,
    camera_matrix: np.ndarray,
    image_size: tuple[int, int],
    sweeps: int = 2,
    start: np.ndarray | None = None,
) -> np.ndarray:
    """The ``points`` ``(N, 3)`` (mm, base frame: marker centres at their height) whose
    ``marker_mm`` marker no scan pose of a ``sweeps``-leg sweep from ``start`` shows whole
    (:func:`seen_whole`), for a camera of ``camera_matrix`` and ``image_size`` (width,
    height px)."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    seen = np.zeros(len(points), dtype=bool)
    half = marker_mm / math.sqrt(2.0)
    for camera in scan_cameras(rig, sweeps, start):
        seen |= seen_whole(camera, camera_matrix, image_size, points, half)
    return points[~seen]


__all__ = ["EDGE_PX", "scan_cameras", "seen_whole", "unseen"]
