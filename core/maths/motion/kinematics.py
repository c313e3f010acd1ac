"""The kinematic model every arm plugin provides, used by planners, the sim and skills.

Units at this interface: millimetres for lengths and positions, degrees for
revolute joints and angles. Implementations convert to radians inside their
maths. Every array method is batched: ``q`` has shape ``(..., n)`` for ``n``
joints and results keep the leading shape, so a planner can ask about 100,000
configurations in one call.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from armtree.errors import Unreachable


@dataclass(frozen=True)
class Joint:
    """One joint: ``kind`` is ``"revolute"`` (degrees) or ``"prismatic"`` (millimetres).

    ``max_speed`` is in degrees or millimetres per second, ``max_accel`` per
    second squared; the emulators move at these rates and trajectories respect them.
    """

    name: str
    kind: str
    lower: float
    upper: float
    max_speed: float = 90.0
    max_accel: float = 360.0

    @property
    def unit(self) -> str:
        """``"deg"`` or ``"mm"``."""
        return "deg" if self.kind == "revolute" else "mm"


@dataclass(frozen=True)
class Constraint:
    """A coupled joint limit as an inequality ``g(q) <= 0`` (q in degrees / mm).

    ``g`` is batched over ``(..., n)`` arrays. ``expr`` is the same inequality as
    text for messages, e.g. ``"35 - (q2 - q1) <= 0"``.
    """

    name: str
    g: Callable[[np.ndarray], np.ndarray]
    expr: str


@dataclass(frozen=True)
class LinkBox:
    """A link's collision and rendering volume: a box of ``size`` (mm) in the link frame.

    ``link`` indexes the frame from :meth:`KinematicModel.link_frames`; ``offset``
    is the box centre's 4x4 pose in that frame.
    """

    name: str
    link: int
    size: tuple[float, float, float]
    offset: np.ndarray = field(default_factory=lambda: np.eye(4))


class KinematicModel(ABC):
    """An arm's geometry: joints and limits, forward and inverse kinematics, link boxes.

    Subclasses set :attr:`name`, :attr:`joints`, :attr:`home` and :attr:`boxes`
    and implement :meth:`link_frames` and :meth:`ik_all`; the rest has batched
    defaults that a subclass may replace with faster closed forms.
    """

    name: str = "arm"
    joints: tuple[Joint, ...] = ()
    #: Coupled limits beyond each joint's own range.
    constraints: tuple[Constraint, ...] = ()
    #: Home configuration, degrees / mm.
    home: np.ndarray = np.zeros(0)
    #: Tool-centre offset from the last link frame, mm (x, y, z).
    tool_offset: np.ndarray = np.zeros(3)
    #: Link volumes for collision checking and rendering.
    boxes: tuple[LinkBox, ...] = ()
    #: Pairs of box indices that can touch each other (self-collision candidates).
    self_collision_pairs: tuple[tuple[int, int], ...] = ()

    @property
    def dof(self) -> int:
        """Number of joints."""
        return len(self.joints)

    @property
    def lower(self) -> np.ndarray:
        """Lower joint limits, degrees / mm."""
        return np.array([j.lower for j in self.joints], dtype=float)

    @property
    def upper(self) -> np.ndarray:
        """Upper joint limits, degrees / mm."""
        return np.array([j.upper for j in self.joints], dtype=float)

    @abstractmethod
    def link_frames(self, q: np.ndarray) -> np.ndarray:
        """Pose of every link frame in the base frame: ``(..., L, 4, 4)``, mm.

        The last frame is the tool centre point (the tool offset applied).
        """

    @abstractmethod
    def ik_all(self, target: np.ndarray) -> np.ndarray:
        """All inverse-kinematics solutions: ``(..., S, n)``; NaN rows where a branch fails.

        ``target`` is ``(..., 3)`` tool positions in mm for positioning arms, or
        ``(..., 4, 4)`` tool poses for arms that control orientation. Solutions
        outside the joint limits or constraints are NaN.
        """

    def fk(self, q: np.ndarray) -> np.ndarray:
        """Tool pose in the base frame, ``(..., 4, 4)``, mm."""
        return self.link_frames(np.asarray(q, dtype=float))[..., -1, :, :]

    def position(self, q: np.ndarray) -> np.ndarray:
        """Tool position in the base frame, ``(..., 3)``, mm."""
        return self.fk(q)[..., :3, 3]

    def within_limits(self, q: np.ndarray, tol: float = 1e-9) -> np.ndarray:
        """Boolean ``(...)``: each joint in range and every constraint satisfied."""
        q = np.asarray(q, dtype=float)
        # array methods rather than np.all: every inverse-kinematics call comes through here
        ok = ((q >= self.lower - tol) & (q <= self.upper + tol)).all(axis=-1)
        for c in self.constraints:
            ok &= np.asarray(c.g(q)) <= tol
        return ok & np.isfinite(q).all(axis=-1)

    def ik(self, target: np.ndarray, near: np.ndarray | None = None) -> np.ndarray:
        """One solution for one target, the nearest to ``near`` (default: home).

        Raises :class:`~armtree.errors.Unreachable` naming the target when no
        solution is within the limits.
        """
        target = np.asarray(target, dtype=float)
        if not np.isfinite(target).all():
            raise Unreachable(f"target {target.tolist()} is not finite")
        ref = self.home if near is None else np.asarray(near, dtype=float)
        sols = self.ik_all(target, **self.ik_starts(ref))
        sols = sols[np.isfinite(sols).all(axis=-1)]
        if len(sols) == 0:
            shown = target[:3, 3] if target.shape == (4, 4) else target
            raise Unreachable(
                f"{self.name}: target {np.round(shown, 2).tolist()} mm is outside the workspace "
                "or the joint limits"
            )
        return sols[np.argmin(np.linalg.norm(sols - ref, axis=-1))]

    def ik_starts(self, near: np.ndarray) -> dict[str, Any]:
        """What :meth:`ik` passes :meth:`ik_all` to find a solution near ``near`` (degrees /
        mm): nothing by default; a numerical solver's model returns its starts, ``near``
        first."""
        return {}

    def jacobian(self, q: np.ndarray, eps: float = 1e-4) -> np.ndarray:
        """Positional Jacobian ``(..., 3, n)`` in mm per degree (or mm per mm), central differences."""
        q = np.asarray(q, dtype=float)
        n = self.dof
        steps = np.eye(n) * eps
        plus = self.position(q[..., None, :] + steps)
        minus = self.position(q[..., None, :] - steps)
        return np.swapaxes((plus - minus) / (2 * eps), -1, -2)

    def box_poses(self, q: np.ndarray) -> np.ndarray:
        """Pose of every link box centre, ``(..., B, 4, 4)``, mm."""
        return self.box_poses_in(self.link_frames(np.asarray(q, dtype=float)))

    def box_poses_in(self, frames: np.ndarray) -> np.ndarray:
        """:meth:`box_poses` from link frames already computed by :meth:`link_frames`."""
        idx, offsets = self._box_links_and_offsets()
        return frames[..., idx, :, :] @ offsets

    def _box_links_and_offsets(self) -> tuple[np.ndarray, np.ndarray]:
        """Each box's link index ``(B,)`` and offset ``(B, 4, 4)``, stacked once per ``boxes``."""
        # The simulator asks for box poses every tick; the boxes change only when reassigned.
        cached = getattr(self, "_box_arrays", None)
        if cached is None or cached[0] is not self.boxes:
            idx = np.array([b.link for b in self.boxes], dtype=np.intp)
            cached = (self.boxes, idx, np.stack([b.offset for b in self.boxes]))
            self._box_arrays = cached
        return cached[1], cached[2]

    def box_sizes(self) -> np.ndarray:
        """Box sizes ``(B, 3)``, mm."""
        return np.array([b.size for b in self.boxes], dtype=float)
