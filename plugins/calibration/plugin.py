"""Registration of the calibration plugin: the behaviours calibration trees are made of,
``armtree calibrate`` and ``armtree experiment``."""

from __future__ import annotations

from typing import Any

import armtree

from .behaviours import FitCalibration, PlanPoses, VisitPoses, WriteCalibration


@armtree.hookimpl
def armtree_behaviours() -> dict[str, Any]:
    """plan_poses, visit_poses, fit_calibration and write_calibration."""
    return {
        "plan_poses": PlanPoses,
        "visit_poses": VisitPoses,
        "fit_calibration": FitCalibration,
        "write_calibration": WriteCalibration,
    }


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """``calibrate`` (camera, hand-eye, correction, camera-offset, kinematics) and ``experiment``."""
    from .command import CalibrateCommand

    return {"calibrate": CalibrateCommand()}
