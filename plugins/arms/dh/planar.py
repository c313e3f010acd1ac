"""Closed-form inverse kinematics for a hobby arm's usual shape, found in its DH table.

Most desktop arms (the Lynxmotion AL5 kind) turn on a vertical base joint and then
bend in one vertical plane through it: shoulder, elbow and wrist pitch, three
parallel axes, perhaps followed by a wrist roll about the tool's own axis. When
position targets keep the tool's axis along a given direction (``tool_axis``),
that shape has a closed form: the base turns the plane towards the target, the
axis fixes the wrist's angle in the plane, so the wrist joint's position follows,
and the shoulder and elbow are a two-link triangle (elbow up, elbow down).

:meth:`PlanarWrist.detect` recognises the shape from the model's own forward
kinematics, not from the table's symbols, and is accepted only when its planar
model reproduces the DH chain at many random configurations, so a table of
another shape simply keeps the damped least squares. Angles in degrees at the
edges, radians inside; lengths mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Configurations the planar model must reproduce before it is trusted.
CHECKS = 64
#: Largest disagreement (mm, and radians for the axis) accepted in those checks.
CHECK_TOL = 1e-6


@dataclass(frozen=True)
class PlanarWrist:
    """Base yaw (joint 0), pitch joints ``pitch`` (three, in order), free joints ``free``.

    Plane coordinates are ``(rho, h)``: horizontal distance along the plane's
    direction and height. At the reference configuration ``q_ref`` the plane's
    direction is ``rho_ref`` (unit, base frame), the shoulder axis is at
    ``shoulder``, the links from shoulder to elbow and elbow to wrist have
    lengths ``l2``, ``l3`` and angles ``a2_ref``, ``a3_ref``; ``tip_ref`` and
    ``axis_ref`` are the wrist-to-tool vector and the tool axis in the plane.
    ``signs`` turn each joint's value into a rotation in the plane (and the
    base's into a turn about z).
    """

    q_ref: np.ndarray
    rho_ref: np.ndarray
    base_xy: np.ndarray
    shoulder: np.ndarray
    l2: float
    l3: float
    a2_ref: float
    a3_ref: float
    tip_ref: np.ndarray
    axis_ref: np.ndarray
    signs: np.ndarray
    pitch: tuple[int, int, int]
    free: tuple[int, ...]

    # ------------------------------------------------------------------ recognising

    @classmethod
    def detect(cls, model) -> PlanarWrist | None:
        """The planar description of ``model`` (a DHModel with ``tool_axis``), or None."""
        if model.tool_axis is None or model.dof < 4 or not np.all(model._revolute):
            return None
        q_ref = np.asarray(model.home, dtype=float)
        axes, points, tool = _frames(model, q_ref)
        up = np.array([0.0, 0.0, 1.0])
        if abs(abs(axes[0] @ up) - 1.0) > 1e-9:
            return None
        pitch_axis = axes[1]
        if abs(pitch_axis @ up) > 1e-9:
            return None
        pitch = tuple(i for i in range(1, model.dof) if abs(abs(axes[i] @ pitch_axis) - 1.0) < 1e-9)
        if pitch != (1, 2, 3):
            return None
        rho = np.cross(pitch_axis, up)
        rho /= np.linalg.norm(rho)
        base_xy = points[0][:2]

        def plane(p: np.ndarray) -> np.ndarray:
            return np.array([(p[:2] - base_xy) @ rho[:2], p[2]])

        normal = np.cross(np.append(rho[:2], 0.0), up)  # turning about it lifts rho
        signs = np.array(
            [np.sign(axes[0] @ up)] + [np.sign(axes[i] @ normal) for i in range(1, model.dof)]
        )
        s, e, w = (plane(points[i]) for i in pitch)
        d2, d3 = e - s, w - e
        found = cls(
            q_ref=q_ref,
            rho_ref=rho[:2],
            base_xy=base_xy,
            shoulder=s,
            l2=float(np.hypot(*d2)),
            l3=float(np.hypot(*d3)),
            a2_ref=float(np.arctan2(d2[1], d2[0])),
            a3_ref=float(np.arctan2(d3[1], d3[0])),
            tip_ref=plane(tool[:3, 3]) - w,
            axis_ref=np.array([tool[:3, 2][:2] @ rho[:2], tool[2, 2]]),
            signs=signs,
            pitch=pitch,
            free=tuple(i for i in range(1, model.dof) if i not in pitch),
        )
        return found if found._agrees(model) else None

    def _agrees(self, model) -> bool:
        """The planar model's tool position and axis equal the DH chain's at random joints."""
        if self.l2 < 1e-6 or self.l3 < 1e-6:
            return False
        rng = np.random.default_rng(7)
        q = rng.uniform(model.lower, model.upper, (CHECKS, model.dof))
        tool = model.fk(q)
        pos, axis = self.forward(q)
        return bool(
            np.all(np.abs(pos - tool[:, :3, 3]) < CHECK_TOL * 1e3)
            and np.all(np.abs(axis - tool[:, :3, 2]) < CHECK_TOL)
        )

    # ------------------------------------------------------------------ the planar model

    def forward(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tool positions ``(N, 3)`` and axes ``(N, 3)`` for joints ``(N, n)`` (degrees)."""
        q = np.atleast_2d(q)
        d = np.radians(q - self.q_ref) * self.signs
        yaw = d[:, 0]
        i2, i3, i4 = self.pitch
        a2 = self.a2_ref + d[:, i2]
        a3 = self.a3_ref + d[:, i2] + d[:, i3]
        turn = d[:, i2] + d[:, i3] + d[:, i4]
        wrist = (
            self.shoulder
            + self.l2 * np.stack([np.cos(a2), np.sin(a2)], -1)
            + self.l3 * np.stack([np.cos(a3), np.sin(a3)], -1)
        )
        tip = wrist + _rotate(self.tip_ref, turn)
        axis = _rotate(self.axis_ref, turn)
        rho = _rotate(self.rho_ref, yaw)  # (N, 2)
        pos = np.column_stack([self.base_xy + rho * tip[:, :1], tip[:, 1]])
        return pos, np.column_stack([rho * axis[:, :1], axis[:, 1]])

    def solve(self, targets: np.ndarray, axis: np.ndarray, free: np.ndarray) -> np.ndarray:
        """All solutions ``(T, 4, n)`` (degrees) for positions ``(T, 3)`` with the tool along
        ``axis``: two base turns by elbow up and down; free joints take ``free``'s values.
        NaN where a branch has no solution (out of reach, or the axis leaves the plane)."""
        targets = np.atleast_2d(targets)
        n_t = len(targets)
        out = np.full((n_t, 4, len(self.q_ref)), np.nan)
        rel = targets[:, :2] - self.base_xy
        heading = np.arctan2(rel[:, 1], rel[:, 0])
        ref = np.arctan2(self.rho_ref[1], self.rho_ref[0])
        reach = np.hypot(rel[:, 0], rel[:, 1])
        i2, i3, i4 = self.pitch
        for k, flip in enumerate((1.0, -1.0)):
            yaw = heading - ref + (0.0 if flip > 0 else np.pi)
            rho = np.stack([np.cos(yaw + ref), np.sin(yaw + ref)], -1)
            lateral = rho[:, 0] * axis[1] - rho[:, 1] * axis[0]
            ok_axis = np.abs(lateral) < 1e-9
            a_rho = rho @ axis[:2]
            turn = np.arctan2(axis[2], a_rho) - np.arctan2(self.axis_ref[1], self.axis_ref[0])
            tip = np.column_stack([flip * reach, targets[:, 2]])
            wrist = tip - _rotate(self.tip_ref, turn)
            dv = wrist - self.shoulder
            dist2 = np.einsum("ij,ij->i", dv, dv)
            cos_b = (dist2 - self.l2**2 - self.l3**2) / (2.0 * self.l2 * self.l3)
            inside = ok_axis & (np.abs(cos_b) <= 1.0 + 1e-12)
            for j, elbow in enumerate((1.0, -1.0)):
                b = elbow * np.arccos(np.clip(cos_b, -1.0, 1.0))
                a2 = np.arctan2(dv[:, 1], dv[:, 0]) - np.arctan2(
                    self.l3 * np.sin(b), self.l2 + self.l3 * np.cos(b)
                )
                a3 = a2 + b
                d = np.zeros((n_t, len(self.q_ref)))
                d[:, 0] = yaw
                d[:, i2] = a2 - self.a2_ref
                d[:, i3] = a3 - self.a3_ref - d[:, i2]
                d[:, i4] = turn - d[:, i2] - d[:, i3]
                q = self.q_ref + np.degrees(d * self.signs)
                for f in self.free:
                    q[:, f] = free[f]
                out[:, 2 * k + j] = np.where(inside[:, None], q, np.nan)
        return out


def _frames(model, q: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray]:
    """Each joint's axis direction and a point on it, and the tool pose, at ``q``."""
    rots, origins = model._chain(np.atleast_2d(q), keep=True)
    pairs = model._axes(rots, origins)
    axes = [z[:, 0] for z, _ in pairs]
    points = [p[:, 0] for _, p in pairs]
    return axes, points, model.fk(q)


def _rotate(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Plane vector ``v`` (2,) turned by ``angle`` (N,) radians: ``(N, 2)``."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[0] - s * v[1], s * v[0] + c * v[1]], -1)
