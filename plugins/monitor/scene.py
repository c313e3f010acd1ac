"""The arm, the objects, the camera's view and the planned path, as numbers to draw.

:class:`SceneSampler` reads what a person wants to see around the tree: the
arm's link boxes and tool from its *reported* joints (what the skills know),
the objects the ``armtree_scene_objects`` hook offers (in simulation: ground
truth, shown, never used to decide), the newest planned path (from the
planner tap) and the camera's footprint on the table. Poses are
``[x, y, z, qx, qy, qz, qw]`` in mm in the arm's base frame.
"""

from __future__ import annotations

import contextlib
from typing import Any

import numpy as np

from armtree.maths.perception.frames import camera_in_base
from armtree.runtime.runner import Run

from .taps import RigTaps

#: Tool positions kept for the trail, and the distance between two of them (mm).
_TRAIL_POINTS = 400
_TRAIL_STEP_MM = 2.0


def poses(matrices: np.ndarray) -> list[list[float]]:
    """4x4 poses (N, 4, 4) as ``[x, y, z, qx, qy, qz, qw]`` rows, rounded to 0.01 mm / 1e-5."""
    matrices = np.asarray(matrices, dtype=float).reshape(-1, 4, 4)
    if len(matrices) == 0:
        return []
    from scipy.spatial.transform import Rotation  # loaded when a monitored run draws

    quats = Rotation.from_matrix(matrices[:, :3, :3]).as_quat()
    out = np.column_stack([matrices[:, :3, 3].round(2), quats.round(5)])
    return out.tolist()


class SceneSampler:
    """Builds scene snapshots of one run (on the run's thread, a few times per second)."""

    def __init__(self, run: Run, taps: RigTaps | None) -> None:
        self.run = run
        self.taps = taps
        self.trail: list[list[float]] = []
        self._plan_seq = -1
        self._path: list[list[float]] = []

    def objects(self) -> list[Any]:
        """Every object the plugins offer (``armtree_scene_objects``), joined."""
        manager = getattr(self.run, "manager", None)
        if manager is None:
            return []
        found: list[Any] = []
        for result in manager.hook.armtree_scene_objects(run=self.run):
            found.extend(result or ())
        return found

    def sample(self) -> dict[str, Any]:
        """A snapshot: ``t``, ``objects``, ``arm`` (``joints``, ``links``, ``boxes``,
        ``tool``, ``suction``), ``camera`` (``pose``, ``footprint``), ``path``, ``trail``."""
        run = self.run
        objects = self.objects()
        # One rotation-to-quaternion call for every pose of the snapshot.
        object_rows = poses(np.stack([o.pose for o in objects])) if objects else []
        snapshot: dict[str, Any] = {
            "t": run.tick_time,
            "tick": run.tick_count,
            "objects": [
                {
                    "name": o.name,
                    "kind": o.kind,
                    "pose": row,
                    "size": [round(float(v), 2) for v in o.size],
                    "color": [round(float(c), 3) for c in o.color],
                    "held": bool(o.held),
                    "marker": o.marker,
                    "route": [[round(x, 1), round(y, 1)] for x, y in o.route],
                }
                for o, row in zip(objects, object_rows, strict=True)
            ],
            "arm": None,
            "camera": None,
            "path": self._planned_path(),
            "trail": list(self.trail),
        }
        arm = getattr(run.rig, "arm", None)
        model = getattr(arm, "model", None)
        if arm is None or model is None:
            return snapshot
        try:
            q = np.asarray(arm.joints(), dtype=float)
        except Exception:  # noqa: BLE001 - no reading yet (link not up)
            return snapshot
        frames = model.link_frames(q)
        tool = frames[-1]
        boxes = model.box_poses(q) if getattr(model, "boxes", None) else np.zeros((0, 4, 4))
        tip = tool[:3, 3]
        if not self.trail or np.hypot(*(tip[:2] - self.trail[-1][:2])) > _TRAIL_STEP_MM:
            self.trail.append([round(float(v), 1) for v in tip])
            del self.trail[:-_TRAIL_POINTS]
        camera = getattr(run.rig, "camera", None)
        camera_pose = None
        if camera is not None:
            with contextlib.suppress(ValueError):
                camera_pose = camera_in_base(camera.mount, camera.extrinsics, tool)
        extra = [camera_pose] if camera_pose is not None else []
        rows = poses(np.concatenate([frames, boxes, *(p[None] for p in extra)]))
        n, b = len(frames), len(boxes)
        snapshot["arm"] = {
            "joints": [round(float(v), 3) for v in q],
            "links": rows[:n],
            "boxes": rows[n : n + b],
            "sizes": model.box_sizes().round(2).tolist() if b else [],
            "tool": rows[n - 1],
            "suction": bool(getattr(arm.tool, "suction", False)),
        }
        # camera_pose is set only with a camera
        if camera is not None and camera_pose is not None:
            snapshot["camera"] = {
                "mount": camera.mount,
                "pose": rows[n + b],
                "footprint": self._footprint(camera_pose, objects),
            }
        return snapshot

    def _planned_path(self) -> list[list[float]]:
        taps = self.taps
        if taps is None or taps.plan is None:
            return []
        if taps.plan_seq != self._plan_seq:
            self._plan_seq = taps.plan_seq
            model = getattr(getattr(self.run.rig, "arm", None), "model", None)
            if model is None:
                self._path = []
            else:
                self._path = model.position(taps.plan).round(1).tolist()
        return self._path

    def _footprint(self, pose: np.ndarray, objects: list[Any]) -> list[list[float]]:
        """Where the image corners' rays meet the table top (x, y mm), if they do."""
        seen = self.taps.seen if self.taps is not None else None
        table = next((o for o in objects if o.kind == "table"), None)
        k = None if seen is None else seen.frame.camera_matrix
        if seen is None or table is None or k is None:
            return []
        h, w = seen.frame.image.shape[:2]
        px = np.array([[0, 0], [w, 0], [w, h], [0, h]], dtype=float)
        rays = np.column_stack(
            [(px[:, 0] - k[0, 2]) / k[0, 0], (px[:, 1] - k[1, 2]) / k[1, 1], np.ones(4)]
        )
        rays = rays @ pose[:3, :3].T
        top = float(table.pose[2, 3] + 0.5 * table.size[2])
        if np.any(rays[:, 2] >= -1e-6):
            return []
        t = (top - pose[2, 3]) / rays[:, 2]
        return (pose[:3, 3] + rays * t[:, None])[:, :2].round(1).tolist()


__all__ = ["SceneSampler", "poses"]
