"""Round-trip checks shared by the closed-form arm models' property tests (Magician, VICRA)."""

import numpy as np
from hypothesis import strategies as st


def joint_configs(model):
    """Joint vectors within each of ``model``'s joint limits (degrees or mm)."""
    return st.tuples(*[st.floats(j.lower, j.upper, allow_nan=False) for j in model.joints]).map(
        np.array
    )


def assert_ik_of_fk_contains_q(model, q):
    """One of the IK solutions of the pose fk(q) is q itself."""
    sols = model.ik_all(model.fk(q))
    # near the stretched-out singularity acos loses half the digits: 1e-4 deg
    assert np.nanmin(np.abs(sols - q).max(axis=-1)) < 1e-4


def assert_fk_of_ik_is_the_target(model, q):
    """Every finite IK solution of position(q) reaches it, to 1 um; returns the solutions."""
    p = model.position(q)
    sols = model.ik_all(p)
    good = sols[np.all(np.isfinite(sols), axis=-1)]
    assert len(good) >= 1
    np.testing.assert_allclose(
        model.position(good),
        np.broadcast_to(p, good.shape[:-1] + (3,)),
        atol=1e-3,  # 1 um: a limit-value solution may be clamped by 1e-5 deg
    )
    return good
