"""Registration of the calibration plugin: the behaviours calibration trees are made of,
``armtree calibrate`` and ``armtree experiment``."""

from __future__ import annotations

from typing import Any

import armtree

from .behaviours import FitCalibration, PlanPoses, VisitPoses, WriteCalibration
from .trials import PlaceTarget, PlanTargets, RecordTrial


@armtree.hookimpl
def armtree_behaviours() -> dict[str, Any]:
    """plan_poses, visit_poses, fit_calibration, write_calibration (calibration trees) and
    plan_targets, place_target, record_trial (Durovic 2017's experiment 2)."""
    return {
        "plan_poses": PlanPoses,
        "visit_poses": VisitPoses,
        "fit_calibration": FitCalibration,
        "write_calibration": WriteCalibration,
        "plan_targets": PlanTargets,
        "place_target": PlaceTarget,
        "record_trial": RecordTrial,
    }


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """``calibrate`` (camera, hand-eye, correction, camera-offset, kinematics) and ``experiment``."""
    from .command import CalibrateCommand
    from .experiment import ExperimentCommand

    return {"calibrate": CalibrateCommand(), "experiment": ExperimentCommand()}
