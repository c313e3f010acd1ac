"""The simulated world's box-box penetration depth (separating axes, seed 004's collision idea)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.plugins.sim.geometry import obb_penetration, pose, rot_z

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
