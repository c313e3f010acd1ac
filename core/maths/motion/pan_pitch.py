"""Closed-form IK of a desktop arm's usual shape, recognised in any model's kinematics.

Most hobby arms (the SO-101, the Koch) turn on a vertical pan joint and then bend
in one vertical plane: shoulder, elbow and wrist pitch about three parallel
horizontal axes, perhaps followed by a wrist roll. When a position target keeps
the tool's axis along a wanted direction, that shape has a closed form. Unlike
the DH arms' planar wrist, the plane need not pass through the pan axis and the
tool centre need not lie on the roll axis: the bend happens in a plane offset
sideways by ``L`` (the tool's constant coordinate along the pitch axes, for the
free joints' values), so the pan turns the target's direction by ``atan2(L, rho)``
and the in-plane distance is ``sqrt(r^2 - L^2)``.

For free joints (a wrist roll) at given values the reference geometry is taken
from the model's own forward kinematics at those values; the pitch angles follow
from the tool axis (their sum), the wrist point and a two-link triangle (elbow up
and down), for each of the two pan headings. A URDF's figures are rounded (rpy
1.5708 for a right angle), so the axes are parallel and vertical only to about
1e-5: the candidates are that close, and the model polishes them with a few
steps of its own solver and checks them against its forward kinematics. Angles
degrees at the edges, radians inside; lengths mm.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: How far from parallel (and from vertical) the axes may be, as rounded figures leave them.
AXIS_TOL = 1e-4
UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class _Reference:
    """The arm's geometry for one set of free-joint values: see :meth:`PanPitch.solve`."""

    ref: np.ndarray
    s0: float
    u: np.ndarray
    rho: np.ndarray
    base: np.ndarray
    signs: np.ndarray
    shoulder: np.ndarray
    tip: np.ndarray
    lateral: float
    a_ref: float
    l2: float
    l3: float
    alpha2: float
    alpha3: float


@dataclass(frozen=True)
class PanPitch:
    """Joint 0 pans about a vertical axis; joints ``pitch`` (three) bend about parallel
    horizontal axes; joints ``free`` (a roll) keep the values given to :meth:`solve`."""

    pitch: tuple[int, int, int]
    free: tuple[int, ...]
    #: The reference geometry of the last few free-joint values asked about.
    _seen: dict[bytes, _Reference] = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def detect(cls, model: Any) -> PanPitch | None:
        """The shape of ``model`` (one with ``joint_axes(q)`` and revolute joints), or None."""
        if model.dof < 4 or any(j.kind != "revolute" for j in model.joints[:4]):
            return None
        axes, _ = model.joint_axes(np.asarray(model.home, dtype=float))
        if abs(abs(axes[0] @ UP) - 1.0) > AXIS_TOL or abs(axes[1] @ UP) > AXIS_TOL:
            return None
        if any(abs(abs(axes[i] @ axes[1]) - 1.0) > AXIS_TOL for i in (2, 3)):
            return None
        return cls((1, 2, 3), tuple(range(4, model.dof)))

    def solve(
        self, model: Any, targets: np.ndarray, axis: np.ndarray, ref: np.ndarray
    ) -> np.ndarray:
        """Candidate solutions ``(T, 4, n)`` (degrees) for positions ``(T, 3)`` (mm) with the
        tool's z along ``axis``, the free joints at ``ref``'s values: two pan headings by elbow
        up and down, each joint turned into its limits where a whole turn does it. NaN
        where a branch has no triangle; the rest are close, not checked (see the module)."""
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        g = self._reference(model, np.asarray(ref, dtype=float))
        s, tip, lateral, u, rho, base = g.shoulder, g.tip, g.lateral, g.u, g.rho, g.base
        l2, l3, alpha2, alpha3 = g.l2, g.l3, g.alpha2, g.alpha3
        n_t = len(targets)
        out = np.full((n_t, 4, model.dof), np.nan)
        v = targets[:, :2] - base[:2]
        r2 = np.einsum("ij,ij->i", v, v)
        reach = np.sqrt(np.maximum(r2 - lateral**2, 0.0))
        heading = np.arctan2(v[:, 1], v[:, 0])
        for k, flip in enumerate((1.0, -1.0)):
            along = flip * reach
            local = along[:, None] * rho[:2] + lateral * u[:2]
            theta = heading - np.arctan2(local[:, 1], local[:, 0])
            c, sn = np.cos(theta), np.sin(theta)
            turned = np.stack([c * rho[0] - sn * rho[1], sn * rho[0] + c * rho[1]], -1)
            total = np.arctan2(axis[2], turned @ axis[:2]) - g.a_ref  # the pitch turns' sum
            wrist = np.stack([along, targets[:, 2]], -1) - _turn(tip, total)
            dv = wrist - s
            cos_b = (np.einsum("ij,ij->i", dv, dv) - l2**2 - l3**2) / (2.0 * l2 * l3)
            inside = (np.abs(cos_b) <= 1.0 + 1e-12) & (r2 >= lateral**2)
            for j, elbow in enumerate((1.0, -1.0)):
                b = elbow * np.arccos(np.clip(cos_b, -1.0, 1.0))
                beta2 = np.arctan2(dv[:, 1], dv[:, 0]) - np.arctan2(
                    l3 * np.sin(b), l2 + l3 * np.cos(b)
                )
                phi1 = beta2 - alpha2
                phi2 = beta2 + b - alpha3 - phi1
                phi3 = total - phi1 - phi2
                q = np.repeat(g.ref[None, :], n_t, axis=0)
                q[:, 0] += np.degrees(g.s0 * theta)
                # a turn about +u turns the plane's vectors the other way
                for idx, sign, phi in zip(self.pitch, g.signs, (phi1, phi2, phi3), strict=True):
                    q[:, idx] += np.degrees(-sign * phi)
                out[:, 2 * k + j] = np.where(inside[:, None], _wrapped(q, model), np.nan)
        return out

    def _reference(self, model: Any, ref: np.ndarray) -> _Reference:
        """The plane, the links and the tool at ``ref`` (kept for the next call with it)."""
        key = ref.tobytes()
        found = self._seen.get(key)
        if found is not None:
            return found
        axes, points = model.joint_axes(ref)
        tool = model.fk(ref)
        u = axes[1] - (axes[1] @ UP) * UP
        u /= np.linalg.norm(u)
        rho = np.cross(u, UP)
        base = points[0]

        def plane(p: np.ndarray) -> np.ndarray:
            return np.array([(p - base) @ rho, p[2]])

        s, e, w = (plane(points[i]) for i in self.pitch)
        d2, d3 = e - s, w - e
        found = _Reference(
            ref=ref.copy(),
            s0=float(np.sign(axes[0] @ UP)),
            u=u,
            rho=rho,
            base=base,
            signs=np.array([np.sign(axes[i] @ u) for i in self.pitch]),
            shoulder=s,
            tip=plane(tool[:3, 3]) - w,
            lateral=float((tool[:3, 3] - base) @ u),
            a_ref=float(np.arctan2(tool[2, 2], tool[:3, 2] @ rho)),
            l2=float(np.hypot(*d2)),
            l3=float(np.hypot(*d3)),
            alpha2=float(np.arctan2(d2[1], d2[0])),
            alpha3=float(np.arctan2(d3[1], d3[0])),
        )
        if len(self._seen) >= 16:
            self._seen.pop(next(iter(self._seen)))
        self._seen[key] = found
        return found


def _turn(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Plane vector ``v`` (2,) turned by ``angle`` (N,) radians: ``(N, 2)``."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[0] - s * v[1], s * v[0] + c * v[1]], -1)


def _wrapped(q: np.ndarray, model: Any) -> np.ndarray:
    """Each joint turned by a whole turn into its limits where that fits (degrees)."""
    turns = q[None] + np.array([0.0, 360.0, -360.0])[:, None, None]
    inside = (turns >= model.lower - 1e-9) & (turns <= model.upper + 1e-9)
    pick = np.argmax(inside, axis=0)
    return np.take_along_axis(turns, pick[None], axis=0)[0]
