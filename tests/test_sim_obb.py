"""The simulated world's box-box penetration depth (separating axes, Showers 2016's collision idea)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.plugins.sim.geometry import obb_penetration, pose, rot_z
from armtree.plugins.sim.physics import SolidBox, clearly_apart

sizes = st.lists(st.floats(1.0, 80.0), min_size=3, max_size=3)
offsets = st.lists(st.floats(-150.0, 150.0), min_size=3, max_size=3)


@settings(deadline=None)
@given(sa=sizes, sb=sizes, d=offsets, yaw=st.floats(-3.2, 3.2))
def test_penetration_is_symmetric_and_zero_beyond_the_circumscribed_spheres(sa, sb, d, yaw):
    ta = pose(np.eye(3), [0.0, 0.0, 0.0])
    tb = pose(rot_z(yaw), d)
    ab = obb_penetration(ta, sa, tb, sb)
    ba = obb_penetration(tb, sb, ta, sa)
    assert ab >= 0.0 and np.isclose(ab, ba, rtol=1e-9, atol=1e-9)
    reach = 0.5 * (np.linalg.norm(sa) + np.linalg.norm(sb))
    if np.linalg.norm(d) >= reach:
        assert ab == 0.0


def test_boxes_pressed_together_report_their_overlap():
    a = pose(np.eye(3), [0.0, 0.0, 0.0])
    b = pose(np.eye(3), [0.0, 0.0, 25.0])  # 30 mm boxes whose centres are 25 mm apart
    assert np.isclose(obb_penetration(a, [30, 30, 30], b, [30, 30, 30]), 5.0, atol=1e-9)


@settings(deadline=None)
@given(
    sa=sizes,
    sb=sizes,
    direction=offsets,
    yaw=st.floats(-3.2, 3.2),
    apart=st.sampled_from([-1e-3, -1e-12, 0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1.0]),
)
def test_boxes_clearly_apart_are_apart_by_the_exact_tests_too(sa, sb, direction, yaw, apart):
    # spheres placed to touch, overlap or part by amounts down to rounding
    unit = np.asarray(direction) / max(np.linalg.norm(direction), 1e-9)
    reach = 0.5 * (np.linalg.norm(sa) + np.linalg.norm(sb))
    a = SolidBox("a", pose(np.eye(3), [10.0, -20.0, 5.0]), np.asarray(sa))
    b = SolidBox(
        "b", pose(rot_z(yaw), a.pose[:3, 3] + unit * reach * (1.0 + apart)), np.asarray(sb)
    )
    if clearly_apart(a, b):
        gap = np.linalg.norm(b.pose[:3, 3] - a.pose[:3, 3]) - a.radius - b.radius
        assert gap > 0
        assert obb_penetration(a.pose, a.size, b.pose, b.size) == 0.0
    if apart >= 1e-6 and np.linalg.norm(unit) > 0.5:
        assert clearly_apart(a, b)
