"""Reachable workspaces of the shipped arm models: exact reachable() and certified coverings."""

import numpy as np
import pytest

from armtree.maths.motion.workspace import ArmWorkspace
from armtree.plugins.arms.dobot_magician.plugin import magician_factory
from armtree.plugins.arms.dobot_v1.kinematics import DobotV1Model
from armtree.plugins.arms.vicra.plugin import vicra_factory

MODELS = {
    "dobot_v1": lambda: DobotV1Model(),
    "dobot_v1_drop": lambda: DobotV1Model(tool_drop_mm=30.0),
    "magician": lambda: magician_factory.model({}),
    "vicra": lambda: vicra_factory.model({}),
}


def _fk_points(model, n, rng):
    q = model.lower + rng.random((n, model.dof)) * (model.upper - model.lower)
    return model.position(q[model.within_limits(q)])


@pytest.mark.parametrize("name", MODELS)
def test_reachable_agrees_with_inverse_kinematics(name):
    model = MODELS[name]()
    ws = ArmWorkspace(model)
    assert ws.kind == "model" and ws.has_covering
    rng = np.random.default_rng(11)
    lo, hi = ws.bounds
    near = _fk_points(model, 8000, rng)
    x = np.concatenate([rng.uniform(lo, hi, (8000, 3)), near + rng.normal(0, 2.0, near.shape)])
    ik = np.any(np.all(np.isfinite(model.ik_all(x)), axis=-1), axis=-1)
    assert 0.01 < ik.mean() < 0.99
    np.testing.assert_array_equal(ws.reachable(x), ik)
    assert ws.reachable(near).all()


@pytest.mark.parametrize(
    ("name", "delta"), [("dobot_v1", 6.0), ("magician", 30.0), ("vicra", 40.0)]
)
def test_covering_encloses_the_workspace_and_inner_boxes_are_reachable(name, delta):
    model = MODELS[name]()
    cov = ArmWorkspace(model).cover(delta)
    rng = np.random.default_rng(12)
    p = _fk_points(model, 3000, rng)
    lo = np.concatenate([cov.inner_lo, cov.boundary_lo])
    hi = np.concatenate([cov.inner_hi, cov.boundary_hi])
    for s in range(0, len(p), 200):
        chunk = p[s : s + 200, None]
        inside = np.all((chunk >= lo - 1e-9) & (chunk <= hi + 1e-9), axis=-1)
        assert inside.any(axis=1).all()
    assert len(cov.inner_lo) > 0
    k = rng.integers(0, len(cov.inner_lo), 4000)
    pts = cov.inner_lo[k] + rng.random((4000, 3)) * (cov.inner_hi[k] - cov.inner_lo[k])
    sols = model.ik_all(pts)
    assert np.all(np.any(np.all(np.isfinite(sols), axis=-1), axis=-1))
    size = cov.boundary_hi - cov.boundary_lo
    assert np.all(np.linalg.norm(size, axis=1) <= delta + 1e-9)


def test_finer_coverings_have_less_boundary():
    ws = ArmWorkspace(DobotV1Model())
    coarse, fine = ws.cover(12.0), ws.cover(6.0)
    assert fine.boundary_measure < coarse.boundary_measure
    assert fine.inner_measure >= coarse.inner_measure * 0.99


def test_a_calibrated_dobot_falls_back_to_its_inverse_kinematics():
    # Angle offsets change the geometry the constraints describe: IK decides instead.
    model = DobotV1Model(joint_offsets_deg=(0.0, 2.0, -1.5))
    ws = ArmWorkspace(model)
    assert ws.kind == "ik" and not ws.has_covering
    p = model.position(model.home)
    assert ws.reachable(p) and not ws.reachable(p + np.array([400.0, 0.0, 0.0]))
