"""A start configuration in shallow collision: the short move that leaves the contact.

The joints report where the arm is believed to be; a slipped step can leave that
belief a fraction of a millimetre inside the table while the arm holds something
there. Refusing every move from such a start strands the arm, so (as MoveIt's
FixStartStateCollision adapter does) a planner may plan from the nearest
collision-free configuration instead, reached by a short straight joint move
along which every contact only gets shallower. :func:`escape_start` finds that
move for contacts at most :data:`START_CONTACT_MM` deep and refuses deeper ones;
:func:`~armtree.maths.motion.penetration.leaving_run` is the check a path validator makes of a path that starts in
contact. Depths are mm (:mod:`armtree.maths.motion.penetration`); joints deg / mm.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from armtree.errors import PlanningError

from .collision import CollisionChecker
from .penetration import START_CONTACT_MM, Penetration, leaving_run, penetrations, signed_depths
from .validation import check_config

#: How far past touching (mm) the escape aims, so the free configuration is not on the edge.
CLEARANCE_MM = 0.2

#: Samples along the escape move that are checked to leave every contact.
ESCAPE_SAMPLES = 24


@dataclass(frozen=True)
class StartEscape:
    """The move out of a shallow start contact: from ``start`` to ``free`` (deg / mm)."""

    start: np.ndarray
    free: np.ndarray
    contacts: tuple[Penetration, ...]
    #: The unit of the joint that moves most (``deg`` or ``mm``).
    unit: str = "deg"

    @property
    def depth_mm(self) -> float:
        """The deepest contact at the start, mm."""
        return max(p.depth_mm for p in self.contacts)

    def message(self) -> str:
        """What happened, for the run log and the live view."""
        step = float(np.abs(self.free - self.start).max())
        return (
            "start in collision: "
            + "; ".join(map(str, self.contacts))
            + f"; planned from the nearest free configuration {np.round(self.free, 2).tolist()}"
            + f" ({step:.2f} {self.unit} away), reached by a move that leaves the contact"
        )

    def record(self) -> dict:
        """JSON-safe fields for the run log."""
        return {
            "start": np.round(self.start, 4).tolist(),
            "free": np.round(self.free, 4).tolist(),
            "depth_mm": round(self.depth_mm, 4),
            "contacts": [p.record() for p in self.contacts],
        }


def escape_start(
    checker: CollisionChecker, start: np.ndarray, max_depth: float = START_CONTACT_MM
) -> StartEscape:
    """The short move from ``start`` (in collision) to the nearest free configuration.

    Gauss-Newton steps on the contacts' signed depths (a numerical Jacobian in
    joint space, least-norm steps) aim each contact ``CLEARANCE_MM`` open; the
    straight move from ``start`` to the result must then leave every contact
    monotonically and meet no other. Raises PlanningError (reason
    ``start_in_collision``) naming the contacts and their depths when one is
    deeper than ``max_depth`` mm or no such move is found.
    """
    q0 = np.asarray(start, dtype=float)
    found = penetrations(checker, q0)
    where = f"start {np.round(q0, 2).tolist()} is in collision: "
    listed = "; ".join(map(str, found)) or "; ".join(map(str, checker.contacts(q0)))
    if not found or max(p.depth_mm for p in found) > max_depth:
        raise PlanningError(
            where + listed + f" (deeper than the {max_depth:g} mm a start may be stepped out of)",
            reason="start_in_collision",
        )
    free = _descend(checker, q0, [p.key for p in found])
    if free is None or leaving_run(checker, _segment(q0, free), max_depth) is None:
        raise PlanningError(
            where + listed + "; no short move leaves the contact", reason="start_in_collision"
        )
    unit = checker.model.joints[int(np.argmax(np.abs(free - q0)))].unit
    return StartEscape(q0, free, tuple(found), unit)


def _segment(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    t = np.linspace(0.0, 1.0, ESCAPE_SAMPLES + 1)[:, None]
    return q0 + t * (q1 - q0)


def _descend(
    checker: CollisionChecker, q0: np.ndarray, keys: list, rounds: int = 8, h: float = 1e-3
) -> np.ndarray | None:
    """A valid, collision-free configuration near ``q0`` with contacts ``keys`` open, or None."""
    model = checker.model
    q = q0.copy()
    eye = np.eye(model.dof) * h
    for _ in range(rounds):
        depth = signed_depths(checker, q, keys)
        if np.all(depth < 0) and checker.valid(q):
            return q
        jac = np.stack(
            [
                (signed_depths(checker, q + e, keys) - signed_depths(checker, q - e, keys))
                / (2 * h)
                for e in eye
            ],
            axis=1,
        )
        want = np.minimum(0.0, -CLEARANCE_MM - depth)  # only contacts not yet open move
        step = np.linalg.lstsq(jac, want, rcond=None)[0]
        if not np.all(np.isfinite(step)):
            return None
        q = np.clip(q + step, model.lower, model.upper)
    return q if checker.valid(q) else None


class StartContactRecovery:
    """A planner's way out of shallow start contacts (MoveIt's FixStartStateCollision).

    A planner owns one and calls :meth:`plan` where its start check refused the
    start as in collision. The last start's escape is kept: a planner is asked
    again and again from the same believed start (each inverse-kinematics
    solution, each scan pose) and the escape is the same each time.
    """

    def __init__(self, checker: CollisionChecker, max_depth: float = START_CONTACT_MM) -> None:
        self.checker = checker
        self.max_depth = float(max_depth)
        self._last: tuple[bytes, StartEscape | PlanningError] | None = None

    def escape(self, start: np.ndarray) -> StartEscape:
        """:func:`escape_start` of ``start``, remembered for the next call from there."""
        q = np.asarray(start, dtype=float)
        key = q.tobytes()
        if self._last is None or self._last[0] != key:
            try:
                found: StartEscape | PlanningError = escape_start(self.checker, q, self.max_depth)
            except PlanningError as exc:
                found = exc
            self._last = (key, found)
        found = self._last[1]
        if isinstance(found, PlanningError):
            raise PlanningError(str(found), reason=found.reason)
        return found

    def check(self, start: np.ndarray) -> tuple[np.ndarray, StartEscape | None]:
        """``start`` as :func:`~armtree.maths.motion.validation.check_config` checks it, and
        None; or, when it is in a shallow collision, ``start`` and the move out of it.

        PlanningError as ``check_config`` raises it, or (reason ``start_in_collision``)
        naming the depths when the contact is deeper than ``max_depth`` mm.
        """
        try:
            return check_config(self.checker, start, "start"), None
        except PlanningError as exc:
            if exc.reason != "start_in_collision":
                raise
        return np.asarray(start, dtype=float), self.escape(start)

    def follow(self, planner: Any, escape: StartEscape, goal: np.ndarray) -> np.ndarray:
        """Waypoints ``[start, free, ...]``: ``escape``, then ``planner.plan(free, goal)``;
        ``planner.report`` (when set) is told."""
        path = np.atleast_2d(np.asarray(planner.plan(escape.free, goal), dtype=float))
        report = getattr(planner, "report", None)
        if report is not None:
            report("start_contact", escape.message(), **escape.record())
        return np.vstack([escape.start, path])
