"""The reachable workspaces of the arm families the built-in plugins drive, as constraints.

Each function gives a :class:`~armtree.maths.motion.workspace.WorkspaceShape` that
:class:`~armtree.maths.motion.workspace.ArmWorkspace` covers (Rybak 2016) and tests
points against: the Dobot family (Showers 2016's geometry: base, rear arm, forearm
and a level tool at a horizontal offset; the Dobot V1.0 and the Magician) and
SCARA arms (a vertical axis and two planar links; the VICRA). Units: mm and
degrees at the interface.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from armtree.maths.motion import interval as iv
from armtree.maths.motion.interval import Interval
from armtree.maths.motion.kinematics import KinematicModel
from armtree.maths.motion.workspace import (
    ConstraintSystem,
    WorkspaceShape,
    limits_constraint,
    sector_constraint,
)


def dobot_shape(
    model: KinematicModel, l1: float, l2: float, d: float, drop: float
) -> WorkspaceShape:
    """The workspace of a Dobot-family ``model`` with links ``l1``, ``l2`` and a tool ``d``
    forward of and ``drop`` below the wrist joint (mm)."""
    lo, hi = model.lower, model.upper
    coupled = [c.g for c in model.constraints]
    reach = l1 + l2 + d
    section = dobot_profile(l1, l2, d, lo, hi, coupled, drop)
    sector = sector_constraint(lo[0], hi[0])
    return WorkspaceShape(
        constraints=plane_constraints(section, sector),
        lower=np.array([-reach, -reach, -(l1 + l2) - drop]),
        upper=np.array([reach, reach, l1 + l2 - drop]),
        section=section,
        sector=sector,
    )


def scara_shape(
    model: KinematicModel, l1: float, l2: float, z_offset: float = 0.0
) -> WorkspaceShape:
    """The workspace of a SCARA ``model``: a prismatic column (joint 0) and planar links
    ``l1``, ``l2`` (mm); the tool sits ``z_offset`` above the column's reading."""
    lo, hi = model.lower, model.upper
    reach = l1 + l2
    return WorkspaceShape(
        constraints=scara_constraints(l1, l2, lo, hi, z_offset, [c.g for c in model.constraints]),
        lower=np.array([-reach, -reach, lo[0] + z_offset]),
        upper=np.array([reach, reach, hi[0] + z_offset]),
    )


def plane_constraints(
    section: Callable[[Any, Any], list[Any]], sector: Callable[[Any], Any] | None
) -> ConstraintSystem:
    """``g_j(x, y, z) <= 0`` of an arm whose reach in its vertical plane is ``section(r, z)``
    (``r`` the distance from the base axis, mm), turned by a base joint within ``sector``."""

    def system(p: Any) -> list[Any]:
        gs = section(iv.hypot(p[..., 0], p[..., 1]), p[..., 2])
        if sector is not None:
            gs.append(sector(p))
        return gs

    return system


def dobot_profile(
    l1: float,
    l2: float,
    d: float,
    lower: Sequence[float] | np.ndarray,
    upper: Sequence[float] | np.ndarray,
    coupled: Sequence[Callable[[Any], Any]] = (),
    drop: float = 0.0,
) -> Callable[[Any, Any], list[Any]]:
    """Reachability of a Dobot-style arm (Showers 2016 geometry) in its plane: ``g_j(r, z) <= 0``, mm.

    ``r`` is the tool's distance from the base axis: everything but the base
    joint's sector depends on (r, z) alone. The inverse kinematics of Showers 2016
    (eqs. 8-10) written in interval-friendly operations: theta1 = 90 deg - phi -
    alpha, theta2 = 180 deg - phi - alpha - gamma for the elbow-up branch (and the
    elbow-down branch too, the union of both), each held to the joint limits
    ``lower``/``upper`` (deg; joint 0 is the base, 1 the rear arm, 2 the forearm,
    any further joints do not move the tool) and to the ``coupled`` constraints
    ``c(q_deg) <= 0`` (Showers 2016, eq. 4). ``d`` is the horizontal wrist-to-tool
    offset, ``drop`` the tool below the wrist. :func:`plane_constraints` turns it
    into 3-D constraints.
    """
    deg = 180.0 / np.pi

    def system(r: Any, z: Any) -> list[Any]:
        z = z + drop
        rw = r - d  # Showers 2016, eq. 8
        rho2 = rw**2 + z**2
        rho = iv.sqrt(rho2)
        gs = [rho2 - (l1 + l2) ** 2, (l1 - l2) ** 2 - rho2]
        alpha = iv.acos((l1**2 - l2**2 + rho2) / (2 * l1 * rho))  # eq. 9
        gamma = iv.acos((l1**2 + l2**2 - rho2) / (2 * l1 * l2))

        def joints(phi: Any) -> Any:
            up = {
                1: (np.pi / 2 - phi - alpha) * deg,
                2: (np.pi - phi - alpha - gamma) * deg,
            }  # eq. 10
            down = {1: (np.pi / 2 - phi + alpha) * deg, 2: (gamma - np.pi - phi + alpha) * deg}
            return iv.minimum(
                limits_constraint(up, lower, upper, coupled, rw),
                limits_constraint(down, lower, upper, coupled, rw),
            )

        g = joints(iv.atan2(z, rw))
        if isinstance(g, Interval):
            # Boxes behind the wrist axis (rw < 0) across z = 0 straddle atan2's branch
            # cut, where one interval is the whole circle. Bound each side of the cut on
            # its own and take the hull, so those boxes can still be decided.
            cut = (rw.lo < 0) & (z.lo < 0) & (z.hi >= 0)
            if cut.any():
                top = _atan2_corners(Interval(np.maximum(z.lo, 0.0), z.hi), rw, np.pi)
                bottom = _atan2_corners(Interval(z.lo, np.minimum(z.hi, 0.0)), rw, -np.pi)
                ga, gb = joints(top), joints(bottom)
                g = Interval(
                    np.where(cut, np.minimum(ga.lo, gb.lo), g.lo),
                    np.where(cut, np.maximum(ga.hi, gb.hi), g.hi),
                )
        gs.append(g)
        return gs

    return system


def _atan2_corners(y: Interval, x: Interval, on_cut: float) -> Interval:
    """atan2 over boxes on one side of the branch cut, from the corners.

    ``on_cut`` is the value atan2 tends to on the cut from this side (``pi``
    from above, ``-pi`` from below); corners lying on the cut are given it.
    Boxes holding the origin get the whole circle.
    """
    vals = []
    for a in (y.lo, y.hi):
        for b in (x.lo, x.hi):
            v = np.arctan2(a, b)
            vals.append(np.where((a == 0) & (b < 0), on_cut, v))
    lo = np.minimum(np.minimum(vals[0], vals[1]), np.minimum(vals[2], vals[3]))
    hi = np.maximum(np.maximum(vals[0], vals[1]), np.maximum(vals[2], vals[3]))
    origin = (x.lo <= 0) & (x.hi >= 0) & (y.lo <= 0) & (y.hi >= 0)
    return Interval(np.where(origin, -np.pi, lo), np.where(origin, np.pi, hi))


def scara_constraints(
    l1: float,
    l2: float,
    lower: Sequence[float] | np.ndarray,
    upper: Sequence[float] | np.ndarray,
    z_offset: float = 0.0,
    coupled: Sequence[Callable[[Any], Any]] = (),
) -> ConstraintSystem:
    """Reachability of a SCARA arm as ``g_j(x, y, z) <= 0``, mm.

    Joint 0 is the vertical axis (mm; the tool at ``z = q0 + z_offset``), joints
    1 and 2 the shoulder and elbow (deg) of a planar two-link arm ``l1``, ``l2``.
    For each elbow branch the elbow angle is ``+-acos(c2)`` and the shoulder the
    tool's azimuth less the elbow's deflection: the azimuth test is done in the
    frame turned by that deflection, with half-planes (no atan2 branch cut).
    """
    deg = 180.0 / np.pi
    a1, b1 = np.radians(lower[1]), np.radians(upper[1])
    wide = upper[1] - lower[1] > 180.0

    def shoulder_ok(u: Any, v: Any) -> Any:
        left = np.sin(a1) * u - np.cos(a1) * v
        right = np.cos(b1) * v - np.sin(b1) * u
        return iv.minimum(left, right) if wide else iv.maximum(left, right)

    def system(p: Any) -> list[Any]:
        x, y, z = p[..., 0], p[..., 1], p[..., 2] - z_offset
        r2 = x**2 + y**2
        r = iv.sqrt(r2)
        gs = [lower[0] - z, z - upper[0], r2 - (l1 + l2) ** 2, (l1 - l2) ** 2 - r2]
        c2 = (r2 - l1**2 - l2**2) / (2 * l1 * l2)
        t2 = iv.acos(c2)
        s2 = iv.sqrt(1.0 - iv.minimum(c2**2, 1.0))
        branches = []
        for sign in (1.0, -1.0):
            # The tool's azimuth is theta1 + beta with cos(beta) = (l1 + l2 c2) / r,
            # sin(beta) = sign l2 s2 / r; turn the point back by beta (times r).
            cb, sb = l1 + l2 * c2, (l2 * s2) * sign
            u, v = x * cb + y * sb, y * cb - x * sb
            elbow = t2 * (sign * deg)
            g = iv.maximum(
                shoulder_ok(u, v), limits_constraint({2: elbow}, lower, upper, coupled, r)
            )
            branches.append(g)
        gs.append(iv.minimum(branches[0], branches[1]))
        return gs

    return system
