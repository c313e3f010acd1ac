"""An arm model from a URDF file: its chain, joint limits, forward and inverse kinematics, boxes.

URDF (the ROS robot description) joins links by joints: each joint sits at an
``origin`` (``xyz`` metres, ``rpy`` radians: roll about x, then pitch about y,
then yaw about z, all about the parent's fixed axes) in its parent link and turns
about, or slides along, its ``axis``; ``<limit lower upper velocity>`` bounds it
in radians (metres) and radians (metres) a second. yourdfpy reads the file; its
elements' positions, which lxml keeps, name the line of any problem.

:func:`load_urdf` builds a :class:`UrdfModel` of the chain from the base link
(the one no joint moves) to a named tool link, whose frame is the tool centre.
Revolute and prismatic joints on the chain are the arm's joints, in chain
order; fixed joints only carry frames; a continuous joint turns within +-180
degrees. Every link's ``<collision>`` geometry becomes a box: a box as written,
a cylinder or a sphere by the box around it, a mesh by the box around its
vertices when the file is there (a link is only ever checked and drawn as
boxes, so a box in the URDF is enough). Links off the chain (a gripper's moving
jaw) ride on the chain link they hang from, their own joints at zero.

Units at this interface are the project's: millimetres and degrees; the maths
runs in millimetres and radians. Every array method is batched over leading
dimensions like every other kinematic model.
"""

from __future__ import annotations

import io
import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, overload

import numpy as np
from numpy.typing import NDArray

from armtree.errors import ConfigError

from .kinematics import Joint, KinematicModel, LinkBox
from .pan_pitch import PanPitch

#: Attributes that must hold numbers, per element, and how many.
_NUMBERS = {
    "origin": {"xyz": 3, "rpy": 3},
    "axis": {"xyz": 3},
    "limit": {"lower": 1, "upper": 1, "velocity": 1, "effort": 1},
    "box": {"size": 3},
    "cylinder": {"radius": 1, "length": 1},
    "sphere": {"radius": 1},
    "mesh": {"scale": 3},
}
#: Joint types and what they are here.
_KINDS = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic", "fixed": None}
#: Iterations of the damped least squares and how small an error counts as reached (mm).
IK_ITERATIONS = 80
IK_TOL_MM = 0.05
#: How far off (mm, and weighted radians) a closed-form solution may be and still be polished.
POLISH_MM = 5.0
#: Weight of the tool-axis and orientation errors against the position's, mm per radian.
AXIS_WEIGHT = 200.0


@dataclass(frozen=True)
class ChainLink:
    """One joint of the chain: ``origin`` (4x4, mm) in the previous frame, then a turn
    about (or a slide along) ``axis``; ``joint`` is its index among the arm's joints,
    None for a fixed joint. ``link`` names the frame it ends in."""

    name: str
    link: str
    origin: np.ndarray
    axis: np.ndarray
    kind: str | None
    joint: int | None


class UrdfModel(KinematicModel):
    """An arm from a URDF chain (mm and degrees at the edges, radians inside).

    ``link_frames`` returns the base frame and the frame after each joint of the
    chain, fixed ones included: the last is the tool link's, the tool centre.
    ``frame_names`` names them. ``tool_axis`` (a base-frame direction) makes
    position targets keep the tool's z axis along it (a gripper pointing down).
    ``ik_all`` runs damped least squares from ``seeds`` starts at once, within
    the joint limits.
    """

    def __init__(
        self,
        chain: Sequence[ChainLink],
        joints: Sequence[Joint],
        boxes: Sequence[LinkBox] = (),
        *,
        name: str = "urdf",
        base: str = "base",
        home: Sequence[float] | np.ndarray | None = None,
        tool_axis: Sequence[float] | np.ndarray | None = None,
        seeds: int = 12,
        seed: int = 0,
    ) -> None:
        self.name = name
        self.chain = tuple(chain)
        self.joints = tuple(joints)
        self.frame_names = (base, *(c.link for c in self.chain))
        lo, hi = self.lower, self.upper
        start = np.zeros(self.dof) if home is None else np.asarray(home, dtype=float)
        if start.shape != (self.dof,):
            raise ValueError(f"{name}: home lists {start.size} joints, the chain has {self.dof}")
        self.home = np.clip(start, lo, hi)
        self.tool_axis = None if tool_axis is None else _unit(tool_axis)
        self.tool_offset = np.zeros(3)
        rng = np.random.default_rng(seed)
        self.seeds = np.vstack([self.home, rng.uniform(lo, hi, (max(seeds, 1) - 1, self.dof))])
        self._revolute = np.array([j.kind == "revolute" for j in self.joints])
        self._moving = [c for c in self.chain if c.joint is not None]
        # the frame index each joint turns: the frame after its chain entry
        self._joint_frames = np.array([1 + self.chain.index(c) for c in self._moving], dtype=int)
        self._axes = np.array([c.axis for c in self._moving]).reshape(-1, 3)
        self.boxes = tuple(boxes)
        self.self_collision_pairs = self._collision_pairs()
        #: The closed form of a pan-and-three-pitches arm holding ``tool_axis``, when this is one.
        self.closed_form = PanPitch.detect(self) if self.tool_axis is not None else None
        self._recent: dict[tuple, np.ndarray] = {}
        self._recent_lock = threading.Lock()

    # ------------------------------------------------------------------ FK

    def link_frames(self, q: np.ndarray) -> np.ndarray:
        """The base frame and every chain frame, ``(..., len(chain) + 1, 4, 4)``, mm."""
        q = np.asarray(q, dtype=float)
        if q.shape[-1] != self.dof:
            raise ValueError(f"{self.name}: expected {self.dof} joints, got shape {q.shape}")
        lead = q.shape[:-1]
        flat = q.reshape(-1, self.dof)
        out = np.empty((flat.shape[0], len(self.chain) + 1, 4, 4))
        frame = np.broadcast_to(np.eye(4), (flat.shape[0], 4, 4))
        out[:, 0] = frame
        for k, part in enumerate(self.chain, start=1):
            frame = frame @ part.origin
            if part.joint is not None:
                frame = frame @ _motion(part, flat[:, part.joint])
            out[:, k] = frame
        return out.reshape(*lead, len(self.chain) + 1, 4, 4)

    def joint_axes(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each joint's axis direction and a point on it at one configuration ``q``,
        ``(n, 3)`` each, base frame (mm)."""
        frames = self.link_frames(np.asarray(q, dtype=float))[self._joint_frames]
        return np.einsum("nij,nj->ni", frames[:, :3, :3], self._axes), frames[:, :3, 3].copy()

    # ------------------------------------------------------------------ IK

    def ik_all(self, target: np.ndarray, seeds: np.ndarray | None = None) -> np.ndarray:
        """Solutions for ``(..., 3)`` positions or ``(..., 4, 4)`` poses (mm):
        ``(..., S, n)`` degrees, one row per start, NaN where it did not converge within the
        limits; a solution found from two starts is given once."""
        target = np.asarray(target, dtype=float)
        full = target.shape[-2:] == (4, 4)
        if not full and target.shape[-1] != 3:
            raise ValueError(
                f"{self.name}: a target is (..., 3) or (..., 4, 4), not {target.shape}"
            )
        lead = target.shape[:-2] if full else target.shape[:-1]
        flat = target.reshape(-1, 4, 4) if full else target.reshape(-1, 3)
        starts = self.seeds if seeds is None else np.atleast_2d(np.asarray(seeds, dtype=float))
        # the closed form answers position targets only
        closed = None if full else self.closed_form
        key = None
        if target.size <= 16 and (seeds is None or closed is not None):
            # the closed form depends on the first start's free joints only
            free = list(closed.free) if closed is not None else []
            key = (
                target.shape,
                target.tobytes(),
                starts[0][free].tobytes() if closed is not None else b"",
            )
            with self._recent_lock:
                if key in self._recent:
                    return self._recent[key].copy()
        if closed is not None:
            axis = self.tool_axis
            assert axis is not None, "a closed form is only detected for a model with a tool_axis"
            found = np.concatenate(
                [
                    self._polished(closed.solve(self, flat, axis, f), flat)
                    for f in self._free_values(starts[0])
                ],
                axis=1,
            )
            out = _distinct(found).reshape(*lead, found.shape[1], self.dof)
            return self._remembered(key, out)
        n_s = starts.shape[0]
        q = np.tile(np.clip(starts, self.lower, self.upper), (flat.shape[0], 1))
        goals = np.repeat(flat, n_s, axis=0)
        q, err = self._solve(q, goals, full)
        q[~((err < IK_TOL_MM) & self.within_limits(q))] = np.nan
        out = _distinct(q.reshape(flat.shape[0], n_s, self.dof)).reshape(*lead, n_s, self.dof)
        return self._remembered(key, out)

    def _remembered(self, key: tuple | None, out: np.ndarray) -> np.ndarray:
        """``out``, kept under ``key`` for the next question about the same target (skills
        ask whether a point is reachable and then for its solution)."""
        if key is not None:
            with self._recent_lock:
                self._recent[key] = out.copy()
                while len(self._recent) > 16:
                    del self._recent[next(iter(self._recent))]
        return out

    def ik_starts(self, near: np.ndarray) -> dict[str, Any]:
        """``near`` (within the limits) tried first, then the model's seeds."""
        ref = np.clip(np.asarray(near, dtype=float), self.lower, self.upper)
        return {"seeds": np.vstack([ref, self.seeds])}

    def _free_values(self, start: np.ndarray) -> list[np.ndarray]:
        """The closed form's references: the free joints (a roll) as ``start`` has them and
        the first turned half a turn (a tool centre beside the roll axis then reaches the
        other way), the rest at home; each within the limits."""
        free = list(self.closed_form.free) if self.closed_form is not None else []
        out = []
        for turn in (0.0, 180.0):
            q = self.home.copy()
            q[free] = start[free]
            if free:
                k = free[0]
                q[k] = q[k] + turn if q[k] + turn <= self.upper[k] else q[k] - turn
            if turn == 0.0 or self.within_limits(q):
                out.append(np.clip(q, self.lower, self.upper))
        return out

    def _polished(self, candidates: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """Closed-form ``candidates`` ``(T, S, n)`` for position ``targets`` ``(T, 3)``: those
        forward kinematics puts on the target (within the solver's tolerance) as they are,
        those a few millimetres off (rounded figures) taken there by the solver; NaN else."""
        flat = candidates.reshape(-1, self.dof).copy()
        live = np.flatnonzero(np.isfinite(flat).all(axis=1))
        if live.size == 0:
            return candidates
        goals = np.repeat(targets, candidates.shape[1], axis=0)[live]
        err, _ = self._residual(flat[live], goals, False, jacobian=False)
        miss = np.sqrt(np.einsum("mk,mk->m", err, err))
        near = (miss >= IK_TOL_MM) & (miss < POLISH_MM)
        if near.any():
            start = np.clip(flat[live[near]], self.lower, self.upper)
            flat[live[near]], miss[near] = self._solve(start, goals[near], False, 8)
        flat[live[~((miss < IK_TOL_MM) & self.within_limits(flat[live]))]] = np.nan
        return flat.reshape(candidates.shape)

    @overload
    def _residual(
        self, q: np.ndarray, goals: np.ndarray, full: bool, jacobian: Literal[True] = ...
    ) -> tuple[np.ndarray, np.ndarray]: ...

    @overload
    def _residual(
        self, q: np.ndarray, goals: np.ndarray, full: bool, jacobian: Literal[False]
    ) -> tuple[np.ndarray, None]: ...

    def _residual(
        self, q: np.ndarray, goals: np.ndarray, full: bool, jacobian: bool = True
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Errors ``(M, k)`` (mm, and radians times :data:`AXIS_WEIGHT`) and their
        Jacobian ``(M, k, n)`` per degree (or mm) of each joint (None without ``jacobian``)."""
        frames = self.link_frames(q)
        tool = frames[:, -1]
        if not jacobian:
            errors = [(goals[:, :3, 3] if full else goals) - tool[:, :3, 3]]
            if full:
                errors.append(AXIS_WEIGHT * _rotation_error(tool[:, :3, :3], goals[:, :3, :3]))
            elif self.tool_axis is not None:
                errors.append(AXIS_WEIGHT * (self.tool_axis - tool[:, :3, 2]))
            return np.concatenate(errors, axis=1), None
        tip = tool[:, :3, 3]
        at = frames[:, self._joint_frames]  # (M, n, 4, 4)
        axes = np.einsum("mnij,nj->mni", at[:, :, :3, :3], self._axes)  # world axes (M, n, 3)
        points = at[:, :, :3, 3]
        scale = np.where(self._revolute, math.pi / 180.0, 1.0)[None, :, None]
        turning = self._revolute[None, :, None]
        rows = [np.where(turning, np.cross(axes, tip[:, None, :] - points), axes) * scale]
        errors = [(goals[:, :3, 3] if full else goals) - tip]
        if full:
            rows.append(np.where(turning, axes, 0.0) * scale * AXIS_WEIGHT)
            errors.append(AXIS_WEIGHT * _rotation_error(tool[:, :3, :3], goals[:, :3, :3]))
        elif self.tool_axis is not None:
            z = tool[:, :3, 2]
            rows.append(np.where(turning, np.cross(axes, z[:, None, :]), 0.0) * scale * AXIS_WEIGHT)
            errors.append(AXIS_WEIGHT * (self.tool_axis - z))
        jac = np.concatenate(rows, axis=2).transpose(0, 2, 1)
        return np.concatenate(errors, axis=1), jac

    def _solve(
        self, q: np.ndarray, goals: np.ndarray, full: bool, iterations: int = IK_ITERATIONS
    ) -> tuple[np.ndarray, np.ndarray]:
        """Levenberg-Marquardt steps on every problem at once, each clamped to the limits;
        returns the joints and each problem's remaining error (mm)."""
        damping = np.full(q.shape[0], 1.0)
        err, jac = self._residual(q, goals, full)
        cost = np.einsum("mk,mk->m", err, err)
        live = np.ones(q.shape[0], dtype=bool)
        eye = np.eye(err.shape[1])
        for _ in range(iterations):
            idx = np.flatnonzero(live)
            if idx.size == 0:
                break
            j, e, here = jac[idx], err[idx], q[idx]
            step = _damped_step(j, e, damping[idx], eye)
            # a joint at a limit that the step pushes further out is held there and the
            # step taken with the others (else clipping leaves the rest stuck short of it)
            held = ((here <= self.lower + 1e-9) & (step < 0)) | (
                (here >= self.upper - 1e-9) & (step > 0)
            )
            if held.any():
                rows = held.any(axis=1)
                free = j[rows] * ~held[rows][:, None, :]
                step[rows] = _damped_step(free, e[rows], damping[idx][rows], eye)
            trial = np.clip(here + step, self.lower, self.upper)
            e2, j2 = self._residual(trial, goals[idx], full)
            c2 = np.einsum("mk,mk->m", e2, e2)
            better = c2 < cost[idx]
            keep = idx[better]
            q[keep], err[keep], jac[keep], cost[keep] = (
                trial[better],
                e2[better],
                j2[better],
                c2[better],
            )
            # a floor keeps J J^T + damping invertible where the task has more rows than joints
            damping[keep] = np.maximum(damping[keep] * 0.5, 1e-3)
            damping[idx[~better]] *= 3.0
            live[idx] = (np.sqrt(cost[idx]) >= IK_TOL_MM) & (damping[idx] < 1e5)
        return q, np.sqrt(cost)

    # ------------------------------------------------------------------ boxes

    def _collision_pairs(self) -> tuple[tuple[int, int], ...]:
        """Boxes two or more moving joints apart, and apart at home (those touching at home
        are built so)."""
        if not self.boxes:
            return ()
        moved = np.concatenate([[0], np.cumsum([c.joint is not None for c in self.chain])])
        poses = self.box_poses(self.home)
        radii = 0.5 * np.linalg.norm(self.box_sizes(), axis=1)
        pairs = []
        for i, a in enumerate(self.boxes):
            for j in range(i + 1, len(self.boxes)):
                b = self.boxes[j]
                apart = np.linalg.norm(poses[i, :3, 3] - poses[j, :3, 3]) > radii[i] + radii[j]
                if abs(int(moved[a.link]) - int(moved[b.link])) >= 2 and apart:
                    pairs.append((i, j))
        return tuple(pairs)


# ---------------------------------------------------------------------- loading


def load_urdf(
    path: str | Path,
    tool_link: str,
    *,
    base_link: str | None = None,
    name: str | None = None,
    home: Sequence[float] | None = None,
    tool_axis: Sequence[float] | None = None,
    max_accel: float = 360.0,
    speed_default: float = 90.0,
    seeds: int = 12,
) -> UrdfModel:
    """The :class:`UrdfModel` of ``path``'s chain from ``base_link`` (default: the root) to
    ``tool_link``. ``max_accel`` (deg/s^2, mm/s^2) bounds every joint; a joint whose
    ``<limit velocity>`` is missing or 0 turns at ``speed_default`` (deg/s, mm/s).

    Raises :class:`ConfigError` with the file, line and column of what is wrong: a file
    that is not XML or not a URDF, a number that is not one, no link called
    ``tool_link`` or no chain to it, a joint on the chain without limits or of a kind
    an arm does not have, a mesh file that is not there.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ConfigError(f"cannot read the URDF file: {exc.strerror or exc}", str(path)) from exc
    doc = _Document(path, data)
    robot = doc.robot()
    links = {link.name: link for link in robot.links}
    parents = {j.child: j for j in robot.joints}
    for wanted in (tool_link, base_link):
        if wanted is not None and wanted not in links:
            raise doc.error(doc.root, f"no link called {wanted!r} (links: {', '.join(links)})")
    chain_joints: list[Any] = []  # yourdfpy's joints: the library has no type information
    link = tool_link
    while link != base_link and link in parents:
        if len(chain_joints) > len(robot.joints):
            raise doc.error(doc.element("link", tool_link), f"the joints above {tool_link!r} loop")
        chain_joints.append(parents[link])
        link = parents[link].parent
    base = link
    if base_link is not None and base != base_link:
        raise doc.error(
            doc.element("link", tool_link),
            f"no chain of joints leads from {base_link!r} to the tool link {tool_link!r} "
            f"(it hangs from {base!r})",
        )
    chain_joints.reverse()
    chain: list[ChainLink] = []
    joints: list[Joint] = []
    for joint in chain_joints:
        chain.append(_chain_link(doc, joint, len(joints)))
        if chain[-1].joint is not None:
            joints.append(_joint(doc, joint, max_accel, speed_default))
    if not joints:
        raise doc.error(
            doc.element("link", tool_link),
            f"no chain of moving joints leads to the tool link {tool_link!r} "
            f"(it hangs from {base!r} by fixed joints or none)",
        )
    frames = {base: 0} | {c.link: k for k, c in enumerate(chain, start=1)}
    boxes = _boxes(doc, robot, frames, parents)
    return UrdfModel(
        chain,
        joints,
        boxes,
        name=name or robot.name or path.stem,
        base=base,
        home=home,
        tool_axis=tool_axis,
        seeds=seeds,
    )


class _Document:
    """The URDF's bytes, its XML tree (positions) and yourdfpy's reading of it (contents)."""

    def __init__(self, path: Path, data: bytes) -> None:
        from lxml import etree

        self.path = path
        self.lines = data.decode("utf-8", "replace").splitlines()
        parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=False)
        try:
            self.root = etree.fromstring(data, parser)
        except etree.XMLSyntaxError as exc:
            line, column = exc.position if exc.position else (exc.lineno, None)
            raise ConfigError(f"not a URDF: {exc.msg}", str(path), line, column) from exc
        if self.root.tag != "robot":
            raise self.error(
                self.root, f"not a URDF: the document is <{self.root.tag}>, not <robot>"
            )
        self._check_numbers()
        self.data = data

    def robot(self):
        import yourdfpy

        try:
            urdf = yourdfpy.URDF.load(
                io.BytesIO(self.data),
                build_scene_graph=False,
                build_collision_scene_graph=False,
                load_meshes=False,
                load_collision_meshes=False,
            )
        except Exception as exc:  # noqa: BLE001 - yourdfpy's own complaints, placed at the robot
            raise self.error(self.root, f"yourdfpy cannot read it: {exc}") from exc
        return urdf.robot

    def error(self, element, message: str) -> ConfigError:
        """A :class:`ConfigError` at ``element``'s line and column."""
        line = getattr(element, "sourceline", None)
        column = None
        if line is not None and 0 < line <= len(self.lines) and isinstance(element.tag, str):
            found = self.lines[line - 1].find(f"<{element.tag}")
            column = found + 1 if found >= 0 else 1
        return ConfigError(message, str(self.path), line, column)

    def element(self, tag: str, name: str):
        """The first ``<tag name=...>`` element (the robot's when there is none)."""
        found = self.root.find(f"{tag}[@name='{name}']") if "'" not in name else None
        return self.root if found is None else found

    def _check_numbers(self) -> None:
        for element in self.root.iter(*_NUMBERS):
            for attribute, count in _NUMBERS[element.tag].items():
                text = element.get(attribute)
                if text is None:
                    continue
                try:
                    values = [float(v) for v in text.split()]
                except ValueError:
                    values = []
                if len(values) != count or not all(math.isfinite(v) for v in values):
                    what = "a number" if count == 1 else f"{count} numbers"
                    raise self.error(
                        element, f'<{element.tag} {attribute}="{text}">: expected {what}'
                    )


def _chain_link(doc: _Document, joint, index: int) -> ChainLink:
    kind = joint.type
    where = doc.element("joint", joint.name)
    if kind not in _KINDS:
        raise doc.error(
            where,
            f"joint {joint.name!r} is {kind}: an arm's chain has revolute, continuous, "
            "prismatic and fixed joints",
        )
    if joint.mimic is not None:
        raise doc.error(where, f"joint {joint.name!r} mimics another: not on an arm's chain")
    origin = np.eye(4) if joint.origin is None else np.array(joint.origin, dtype=float)
    origin[:3, 3] *= 1000.0
    axis = np.array([1.0, 0.0, 0.0] if joint.axis is None else joint.axis, dtype=float)
    moving = _KINDS[kind]
    if moving is not None and not np.linalg.norm(axis) > 1e-9:
        raise doc.error(where, f"joint {joint.name!r} has a zero axis")
    return ChainLink(
        joint.name,
        joint.child,
        origin,
        axis / max(np.linalg.norm(axis), 1e-12),
        moving,
        None if moving is None else index,
    )


def _joint(doc: _Document, joint, max_accel: float, speed_default: float) -> Joint:
    kind = _KINDS[joint.type]
    assert kind is not None, "only the chain's moving joints become the arm's joints"
    limit = joint.limit
    unit = 180.0 / math.pi if kind == "revolute" else 1000.0
    if joint.type == "continuous":
        lower, upper = -180.0, 180.0
    elif limit is None or limit.lower is None or limit.upper is None:
        raise doc.error(
            doc.element("joint", joint.name),
            f"joint {joint.name!r} has no limits: give it "
            f'<limit lower="..." upper="..." velocity="..."/> '
            f"({'radians' if kind == 'revolute' else 'metres'})",
        )
    else:
        lower, upper = limit.lower * unit, limit.upper * unit
        if not lower < upper:
            raise doc.error(
                doc.root.find(f"joint[@name='{joint.name}']/limit"),
                f"joint {joint.name!r}: lower limit {limit.lower:g} is not below upper {limit.upper:g}",
            )
    velocity = getattr(limit, "velocity", None) or 0.0
    speed = velocity * unit if velocity > 0 else speed_default
    return Joint(joint.name, kind, lower, upper, max_speed=speed, max_accel=max_accel)


def _boxes(doc: _Document, robot, frames: dict[str, int], parents: dict) -> tuple[LinkBox, ...]:
    """Every link's collision geometry as boxes on the chain frame it rides on."""
    boxes = []
    for link in robot.links:
        attach = np.eye(4)
        name = link.name
        hops = 0
        while name not in frames:
            joint = parents.get(name)
            if joint is None or hops > len(parents):
                break  # a link on another branch from no chain link: not the arm's
            origin = np.eye(4) if joint.origin is None else np.array(joint.origin, dtype=float)
            attach = origin @ attach
            name = joint.parent
            hops += 1
        if name not in frames:
            continue
        attach[:3, 3] *= 1000.0
        for k, collision in enumerate(link.collisions):
            got = _box(doc, link.name, k, collision)
            if got is None:
                continue
            centre, size = got
            origin = np.eye(4) if collision.origin is None else np.array(collision.origin, float)
            origin[:3, 3] *= 1000.0
            boxes.append(LinkBox(f"{link.name}:{k}", frames[name], size, attach @ origin @ centre))
    return tuple(boxes)


def _box(doc: _Document, link: str, k: int, collision) -> tuple[np.ndarray, tuple] | None:
    """The box (centre pose in the collision frame, size in mm) around one collision geometry."""
    geometry = collision.geometry
    centre = np.eye(4)
    if geometry is None:
        return None
    if geometry.box is not None:
        size = np.asarray(geometry.box.size, dtype=float) * 1000.0
    elif geometry.cylinder is not None:
        r, length = geometry.cylinder.radius, geometry.cylinder.length
        size = np.array([2 * r, 2 * r, length]) * 1000.0
    elif geometry.sphere is not None:
        size = np.full(3, 2 * geometry.sphere.radius * 1000.0)
    elif geometry.mesh is not None:
        centre, size = _mesh_box(doc, link, k, geometry.mesh)
    else:
        return None
    if not np.all(size > 0):
        return None
    return centre, tuple(float(s) for s in size)


def _mesh_box(doc: _Document, link: str, k: int, mesh) -> tuple[np.ndarray, np.ndarray]:
    import yourdfpy

    found = Path(yourdfpy.filename_handler_magic(mesh.filename, dir=str(doc.path.parent)))
    element = doc.root.findall(f"link[@name='{link}']/collision")[k].find("geometry/mesh")
    if not found.is_file():
        raise doc.error(
            element,
            f"mesh file {mesh.filename!r} not found (looked beside {doc.path.name}): armtree "
            'only needs boxes, so give this <collision> a <box size="x y z"/> (metres) '
            "or fix the path",
        )
    import trimesh

    try:
        loaded = trimesh.load(found, force="mesh")
        lo, hi = np.asarray(loaded.bounds, dtype=float)
    except Exception as exc:  # noqa: BLE001 - any unreadable mesh is the same mistake
        raise doc.error(element, f"cannot read mesh {found.name}: {exc}") from exc
    scale = np.ones(3) if mesh.scale is None else np.broadcast_to(mesh.scale, 3)
    centre = np.eye(4)
    centre[:3, 3] = 0.5 * (lo + hi) * scale * 1000.0
    return centre, np.abs(hi - lo) * scale * 1000.0


# ---------------------------------------------------------------------- maths


def _motion(part: ChainLink, values: np.ndarray) -> np.ndarray:
    """The joint's own motion for ``values`` (degrees or mm): ``(N, 4, 4)``."""
    out = np.zeros((values.shape[0], 4, 4))
    out[:, 3, 3] = 1.0
    if part.kind == "prismatic":
        out[:, 0, 0] = out[:, 1, 1] = out[:, 2, 2] = 1.0
        out[:, :3, 3] = values[:, None] * part.axis
        return out
    angle = np.radians(values)
    c, s = np.cos(angle), np.sin(angle)
    along = np.flatnonzero(np.abs(part.axis) == 1.0)
    if along.size:
        # about a frame axis (most joints): the other two axes turn, by the axis's sign
        k = int(along[0])
        i, j = (k + 1) % 3, (k + 2) % 3
        s = s * part.axis[k]
        out[:, k, k] = 1.0
        out[:, i, i] = out[:, j, j] = c
        out[:, i, j], out[:, j, i] = -s, s
        return out
    x, y, z = part.axis
    t = 1.0 - c
    # Rodrigues' rotation about a unit axis
    out[:, 0, 0], out[:, 0, 1], out[:, 0, 2] = t * x * x + c, t * x * y - s * z, t * x * z + s * y
    out[:, 1, 0], out[:, 1, 1], out[:, 1, 2] = t * x * y + s * z, t * y * y + c, t * y * z - s * x
    out[:, 2, 0], out[:, 2, 1], out[:, 2, 2] = t * x * z - s * y, t * y * z + s * x, t * z * z + c
    return out


def _damped_step(
    jac: np.ndarray, err: np.ndarray, damping: np.ndarray, eye: np.ndarray
) -> np.ndarray:
    """Damped least-squares steps ``J^T (J J^T + damping^2 I)^-1 e``, one per problem."""
    lhs = jac @ jac.transpose(0, 2, 1) + damping[:, None, None] ** 2 * eye
    return np.einsum("mkn,mk->mn", jac, np.linalg.solve(lhs, err[..., None])[..., 0])


def _rotation_error(current: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """Rotation vectors (radians, base frame) turning each ``current`` into ``wanted``."""
    from scipy.spatial.transform import Rotation

    local = Rotation.from_matrix(np.swapaxes(current, 1, 2) @ wanted).as_rotvec()
    return np.einsum("mij,mj->mi", current, local)


def _distinct(q: np.ndarray) -> np.ndarray:
    """NaN over any solution that repeats an earlier one for the same target (1e-3 deg)."""
    for j in range(1, q.shape[1]):
        same = np.abs(q[:, :j, :] - q[:, j : j + 1, :]).max(axis=-1) < 1e-3
        q[same.any(axis=1), j, :] = np.nan
    return q


def _unit(vector: Sequence[float] | NDArray[np.float64]) -> np.ndarray:
    """``vector`` scaled to length 1; ValueError unless it is a finite, non-zero [x, y, z]."""
    v = np.asarray(vector, dtype=float)
    norm = float(np.linalg.norm(v))
    if v.shape != (3,) or not math.isfinite(norm) or norm < 1e-9:
        raise ValueError(f"tool_axis must be a non-zero [x, y, z], got {vector!r}")
    return v / norm
