"""Hand-eye calibration from marker views at known tool poses: several methods, one residual.

Each :class:`MarkerView` is one pose of the arm: the tool pose its joints give
(4x4, mm, base frame) and the marker as the camera saw it (pose in the camera
frame). Eye-to-hand (a fixed camera, Durovic 2017) the marker rides on the tool at
``marker_offset`` (tool frame, the paper's ``G_t_M``) and the unknown is the
camera's pose in the base frame; eye-in-hand (the camera on the tool, Showers 2016)
the marker lies still on the table and the unknowns are the camera's pose in the
tool frame and the marker's position.

Methods (:func:`solve`):

* ``three_positions``: Durovic 2017, eqs. 1-7, from views 0, 1 (moved along base x)
  and 2 (then along base y); eye-to-hand only.
* ``pnp``: the marker centres' directions from the camera against where the
  joints put them, by least squares on the image (``cv2.solvePnP`` eye-to-hand,
  scipy eye-in-hand). It leaves out the marker's distance, the least accurate
  thing a camera measures (Durovic 2017's conclusion).
* OpenCV's ``calibrateHandEye`` (``tsai``, ``park``, ``horaud``, ``andreff``,
  ``daniilidis``) and ``calibrateRobotWorldHandEye`` (``shah``, ``li``), on the
  full marker poses. They need the tool to turn about two axes at least; a
  four-axis arm turns it about z only, and they are then reported as degenerate.
  OpenCV builds without them (the 5.0 Python wheels) report them as unavailable.

Every fit is judged by the same residual: how far, across the line of sight, the
marker appears from where the fitted pose predicts it (mm at the marker's
distance), RMS over the views. :class:`DegenerateData` says why views cannot
calibrate and which pose to fix. Units: mm, radians inside, degrees in messages.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np
from numpy.typing import NDArray

from .frames import EYE_IN_HAND, EYE_TO_HAND, eye_to_hand_from_three_positions

#: OpenCV's hand-eye methods by name.
HAND_EYE_METHODS = {
    "tsai": cv2.CALIB_HAND_EYE_TSAI,
    "park": cv2.CALIB_HAND_EYE_PARK,
    "horaud": cv2.CALIB_HAND_EYE_HORAUD,
    "andreff": cv2.CALIB_HAND_EYE_ANDREFF,
    "daniilidis": cv2.CALIB_HAND_EYE_DANIILIDIS,
}
#: OpenCV's robot-world/hand-eye methods by name.
ROBOT_WORLD_METHODS = {
    "shah": cv2.CALIB_ROBOT_WORLD_HAND_EYE_SHAH,
    "li": cv2.CALIB_ROBOT_WORLD_HAND_EYE_LI,
}
#: Fewest seen views each method needs.
MIN_VIEWS = {
    "three_positions": 3,
    "pnp": 6,
    **dict.fromkeys([*HAND_EYE_METHODS, *ROBOT_WORLD_METHODS], 3),
}
#: Spread below which views count as lying on a line (mm, second singular value).
MIN_SPREAD_MM = 5.0


class DegenerateData(ValueError):
    """The views cannot calibrate: :attr:`reason`, and :attr:`pose` to fix when one is to blame."""

    def __init__(
        self, reason: str, pose: Sequence[float] | NDArray[np.float64] | None = None
    ) -> None:
        where = "" if pose is None else f" (fix the pose with the tool at {_mm(pose)})"
        super().__init__(reason + where)
        self.reason = reason
        self.pose = None if pose is None else [round(float(v), 1) for v in pose]


@dataclass
class MarkerView:
    """One pose: the tool pose from the joints (4x4 mm) and the marker's pose in the
    camera frame (``rvec`` radians, ``tvec`` mm), None when the camera did not see it."""

    base_T_tool: np.ndarray
    tvec: np.ndarray | None = None
    rvec: np.ndarray | None = None

    @property
    def seen(self) -> bool:
        """True when the camera saw the marker at this pose."""
        return self.tvec is not None

    @property
    def tool_position(self) -> np.ndarray:
        """The tool centre (mm, base frame)."""
        return np.asarray(self.base_T_tool, dtype=float)[:3, 3]


@dataclass
class HandEyeFit:
    """One method's result.

    ``pose`` is the camera in the base frame (eye-to-hand) or in the tool frame
    (eye-in-hand), 4x4 mm; ``marker`` the marker in the tool frame (eye-to-hand)
    or in the base frame (eye-in-hand), mm; ``residuals_mm`` one lateral residual
    per seen view. ``degenerate`` says why the method could not be trusted here.
    """

    method: str
    pose: np.ndarray | None
    marker: np.ndarray | None
    residuals_mm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    degenerate: str = ""

    @property
    def rms_mm(self) -> float:
        """RMS lateral residual (mm); infinite for a failed or degenerate fit."""
        if self.pose is None or self.degenerate or not len(self.residuals_mm):
            return float("inf")
        return float(np.sqrt(np.mean(self.residuals_mm**2)))

    @property
    def max_mm(self) -> float:
        """Largest lateral residual (mm)."""
        return float(np.max(self.residuals_mm)) if len(self.residuals_mm) else float("inf")


def _mm(xyz: Sequence[float] | NDArray[np.float64]) -> str:
    return f"{np.round(np.asarray(xyz, dtype=float), 1).tolist()} mm"


def _inverse(t: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = t[:3, :3].T
    out[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return out


def _pose(rvec: np.ndarray, tvec: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = cv2.Rodrigues(np.asarray(rvec, dtype=float).reshape(3, 1))[0]
    out[:3, 3] = np.asarray(tvec, dtype=float).reshape(3)
    return out


def _marker_position(view: MarkerView) -> NDArray[np.float64]:
    """The marker's position in the camera frame; refused at a view that did not see it."""
    if view.tvec is None:
        raise DegenerateData(
            "the camera did not see the marker at this pose; only seen views can be fitted",
            view.tool_position,
        )
    return np.asarray(view.tvec, dtype=float)


def _marker_pose(view: MarkerView) -> NDArray[np.float64]:
    """The marker's pose in the camera frame (4x4 mm), which OpenCV's methods need whole."""
    if view.rvec is None:
        raise DegenerateData(
            "OpenCV's methods need the marker's rotation at every pose; this one has none",
            view.tool_position,
        )
    return _pose(view.rvec, _marker_position(view))


def lateral_residuals(predicted: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """Distances (mm) across the line of sight between predicted and measured camera-frame
    points ``(N, 3)``: the image-plane error scaled to the measured point's distance."""
    p, m = np.asarray(predicted, dtype=float), np.asarray(measured, dtype=float)
    dp = p[:, :2] / p[:, 2:3] - m[:, :2] / m[:, 2:3]
    return np.linalg.norm(dp, axis=1) * m[:, 2]


# -------------------------------------------------------------------- checks


def seen_views(views: Sequence[MarkerView], need: int, what: str = "marker") -> list[MarkerView]:
    """The views that saw the marker; :class:`DegenerateData` when fewer than ``need``,
    naming the first pose that did not."""
    seen = [v for v in views if v.seen]
    if len(seen) >= need:
        return seen
    missing = [v for v in views if not v.seen]
    if missing:
        raise DegenerateData(
            f"the camera saw the {what} at {len(seen)} of {len(views)} poses; at least {need} "
            "are needed: the arm hides it or it is outside the image",
            missing[0].tool_position,
        )
    raise DegenerateData(f"{len(views)} poses; at least {need} are needed: add poses")


def check_spread(views: Sequence[MarkerView]) -> None:
    """:class:`DegenerateData` when the tool positions lie (nearly) on a line or one point."""
    points = np.array([v.tool_position for v in views])
    centred = points - points.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False) / np.sqrt(max(1, len(points) - 1))
    if len(s) < 2 or s[1] < MIN_SPREAD_MM:
        far = points[int(np.argmax(np.linalg.norm(centred, axis=1)))]
        raise DegenerateData(
            f"the tool positions lie on a line (spread {s[1] if len(s) > 1 else 0.0:.1f} mm across "
            f"it, at least {MIN_SPREAD_MM:g} needed): move poses off it",
            far,
        )


def turning_axes(views: Sequence[MarkerView]) -> str:
    """Why OpenCV's methods cannot use these tool rotations ("" when they can): they need
    turns of more than 5 degrees about at least two axes."""
    rotations = [np.asarray(v.base_T_tool, dtype=float)[:3, :3] for v in views]
    axes = []
    for r in rotations[1:]:
        rvec = cv2.Rodrigues(r @ rotations[0].T)[0].ravel()
        if np.linalg.norm(rvec) > np.radians(5.0):
            axes.append(rvec / np.linalg.norm(rvec))
    if len(axes) < 2:
        return "the tool hardly turns between the poses"
    a = np.array(axes)
    if np.linalg.svd(a, compute_uv=False)[1] < 0.1 * np.sqrt(len(a)):
        return "the tool turns about one axis only (a four-axis arm): its offset along it is unobservable"
    return ""


def check_three_moves(tools: np.ndarray) -> None:
    """Durovic 2017's positions: 0 -> 1 along base x, 1 -> 2 along base y at the same height."""
    a, b = tools[1] - tools[0], tools[2] - tools[1]
    if np.linalg.norm(a) < 10.0:
        raise DegenerateData("the move 0 -> 1 along x is shorter than 10 mm", tools[1])
    if np.linalg.norm(b) < 10.0:
        raise DegenerateData("the move 1 -> 2 along y is shorter than 10 mm", tools[2])
    if np.degrees(np.arccos(min(1.0, abs(a[0]) / np.linalg.norm(a)))) > 5.0:
        raise DegenerateData("position 1 is not position 0 moved along the base x axis", tools[1])
    if abs(b[2]) > 2.0 or np.degrees(np.arccos(min(1.0, abs(b[1]) / np.linalg.norm(b)))) > 5.0:
        raise DegenerateData(
            "position 2 is not position 1 moved along the base y axis at the same height", tools[2]
        )


# -------------------------------------------------------------------- eye-to-hand


def _e2h_marker_in_camera(
    camera_pose: np.ndarray, views: Sequence[MarkerView], marker: np.ndarray
) -> np.ndarray:
    cam_T_base = _inverse(camera_pose)
    return np.array([(cam_T_base @ v.base_T_tool @ np.append(marker, 1.0))[:3] for v in views])


def _e2h_fit(
    method: str, views: Sequence[MarkerView], pose: np.ndarray, marker: np.ndarray
) -> HandEyeFit:
    measured = np.array([v.tvec for v in views], dtype=float)
    predicted = _e2h_marker_in_camera(pose, views, marker)
    return HandEyeFit(method, pose, marker, lateral_residuals(predicted, measured))


def e2h_three_positions(views: Sequence[MarkerView], marker: np.ndarray) -> HandEyeFit:
    """Durovic 2017, eqs. 1-7 from the first three views (see :func:`check_three_moves`)."""
    three = list(views[:3])
    if len(three) < 3:
        raise DegenerateData(f"the three-position method needs 3 poses, got {len(three)}")
    for k, v in enumerate(three):
        if not v.seen:
            raise DegenerateData(
                f"the camera did not see the marker at position {k}", v.tool_position
            )
    tools = np.array([v.tool_position for v in three])
    check_three_moves(tools)
    seen = [np.asarray(v.tvec, dtype=float) for v in three]
    if np.linalg.norm(np.cross(seen[1] - seen[0], seen[2] - seen[1])) < 1e-3 * np.linalg.norm(
        seen[1] - seen[0]
    ) * np.linalg.norm(seen[2] - seen[1]):
        raise DegenerateData("the camera saw the three positions on a line", tools[2])
    camera_T_base = eye_to_hand_from_three_positions(seen, tools[0], marker)
    return _e2h_fit(
        "three_positions", views, _inverse(camera_T_base), np.asarray(marker, dtype=float)
    )


def e2h_pnp(
    views: Sequence[MarkerView], marker: np.ndarray, guess: np.ndarray | None
) -> HandEyeFit:
    """The camera pose that projects the marker centres (from the joints) where they were seen."""
    obj = np.array([(v.base_T_tool @ np.append(marker, 1.0))[:3] for v in views], dtype=np.float64)
    tv = np.array([v.tvec for v in views], dtype=np.float64)
    img = tv[:, :2] / tv[:, 2:3]
    if guess is not None:
        cam_T_base = _inverse(np.asarray(guess, dtype=float))
        rvec0 = cv2.Rodrigues(cam_T_base[:3, :3])[0]
        ok, rvec, tvec = cv2.solvePnP(
            obj, img, np.eye(3), None, rvec0, cam_T_base[:3, 3].reshape(3, 1).copy(), True,
            cv2.SOLVEPNP_ITERATIVE,
        )  # fmt: skip
    else:
        ok, rvec, tvec = cv2.solvePnP(obj, img, np.eye(3), None, flags=cv2.SOLVEPNP_SQPNP)
    if not ok:
        return HandEyeFit("pnp", None, None, degenerate="solvePnP found no pose")
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, np.eye(3), None, rvec, tvec)
    return _e2h_fit("pnp", views, _inverse(_pose(rvec, tvec)), np.asarray(marker, dtype=float))


def e2h_opencv(views: Sequence[MarkerView], name: str) -> HandEyeFit:
    """OpenCV's hand-eye (or robot-world) method ``name`` written for a fixed camera."""
    g_T_b = [_inverse(np.asarray(v.base_T_tool, dtype=float)) for v in views]
    c_T_m = [_marker_pose(v) for v in views]
    try:
        if name in HAND_EYE_METHODS:
            # G_T_B_i B_T_C C_T_M_i = G_T_M: OpenCV's eye-in-hand equation with the base
            # and the gripper swapped; its "camera to gripper" is the camera in the base.
            r, t = cv2.calibrateHandEye(
                [g[:3, :3] for g in g_T_b], [g[:3, 3] for g in g_T_b],
                [c[:3, :3] for c in c_T_m], [c[:3, 3] for c in c_T_m],
                method=HAND_EYE_METHODS[name],
            )  # fmt: skip
            pose = np.eye(4)
            pose[:3, :3], pose[:3, 3] = r, np.asarray(t).ravel()
            marker = np.mean(
                [(g @ pose @ c)[:3, 3] for g, c in zip(g_T_b, c_T_m, strict=True)], axis=0
            )
        else:
            # M_T_C_i C_T_B = M_T_G G_T_B_i: the marker plays OpenCV's camera and the
            # camera its world (A X = Z B with X = camera_T_base, Z = marker_T_tool).
            m_T_c = [_inverse(c) for c in c_T_m]
            r_x, t_x, r_z, t_z = cv2.calibrateRobotWorldHandEye(
                [m[:3, :3] for m in m_T_c], [m[:3, 3] for m in m_T_c],
                [g[:3, :3] for g in g_T_b], [g[:3, 3] for g in g_T_b],
                method=ROBOT_WORLD_METHODS[name],
            )  # fmt: skip
            cam_T_base = np.eye(4)
            cam_T_base[:3, :3], cam_T_base[:3, 3] = r_x, np.asarray(t_x).ravel()
            m_T_g = np.eye(4)
            m_T_g[:3, :3], m_T_g[:3, 3] = r_z, np.asarray(t_z).ravel()
            pose, marker = _inverse(cam_T_base), _inverse(m_T_g)[:3, 3]
    except cv2.error as exc:
        return HandEyeFit(name, None, None, degenerate=f"OpenCV refused: {exc.msg or exc}")
    if not np.all(np.isfinite(pose)):
        return HandEyeFit(name, None, None, degenerate="OpenCV returned no finite pose")
    return _e2h_fit(name, views, pose, marker)


# -------------------------------------------------------------------- eye-in-hand


def _eih_marker_in_camera(
    tool_T_camera: np.ndarray, views: Sequence[MarkerView], marker: np.ndarray
) -> np.ndarray:
    return np.array(
        [
            (
                _inverse(np.asarray(v.base_T_tool, dtype=float) @ tool_T_camera)
                @ np.append(marker, 1.0)
            )[:3]
            for v in views
        ]
    )


def _eih_fit(
    method: str, views: Sequence[MarkerView], pose: np.ndarray, marker: np.ndarray
) -> HandEyeFit:
    measured = np.array([v.tvec for v in views], dtype=float)
    predicted = _eih_marker_in_camera(pose, views, marker)
    return HandEyeFit(
        method, pose, np.asarray(marker, dtype=float), lateral_residuals(predicted, measured)
    )


def eih_pnp(views: Sequence[MarkerView], guess: np.ndarray, marker_z: float | None) -> HandEyeFit:
    """The camera on the tool and the still marker's position, by least squares on the
    marker's directions from the camera; with ``marker_z`` (the table's height) the
    marker's height is held, which a four-axis arm could not tell from the camera's."""
    guess = np.asarray(guess, dtype=float)
    seen_from = [v.base_T_tool @ guess @ np.append(_marker_position(v), 1.0) for v in views]
    marker0 = np.mean(seen_from, axis=0)[:3]
    tv = np.array([v.tvec for v in views], dtype=float)
    directions = tv[:, :2] / tv[:, 2:3]
    free_z = marker_z is None

    def unpack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        pose = _pose(x[:3], x[3:6])
        marker = np.array([x[6], x[7], x[8] if marker_z is None else float(marker_z)])
        return pose, marker

    def residuals(x: np.ndarray) -> np.ndarray:
        pose, marker = unpack(x)
        p = _eih_marker_in_camera(pose, views, marker)
        return ((p[:, :2] / p[:, 2:3] - directions) * tv[:, 2:3]).ravel()

    x0 = np.concatenate(
        [
            cv2.Rodrigues(guess[:3, :3])[0].ravel(),
            guess[:3, 3],
            marker0[:2],
            marker0[2:] if free_z else [],
        ]
    )
    # Imported here: scipy.optimize is slow to import and only a fit needs it.
    from scipy.optimize import least_squares

    solution = least_squares(residuals, x0, method="lm" if len(views) * 2 > len(x0) else "trf")
    pose, marker = unpack(solution.x)
    return _eih_fit("pnp", views, pose, marker)


def eih_opencv(views: Sequence[MarkerView], name: str) -> HandEyeFit:
    """OpenCV's hand-eye (or robot-world) method ``name``, camera on the tool."""
    b_T_g = [np.asarray(v.base_T_tool, dtype=float) for v in views]
    c_T_m = [_marker_pose(v) for v in views]
    try:
        if name in HAND_EYE_METHODS:
            r, t = cv2.calibrateHandEye(
                [b[:3, :3] for b in b_T_g], [b[:3, 3] for b in b_T_g],
                [c[:3, :3] for c in c_T_m], [c[:3, 3] for c in c_T_m],
                method=HAND_EYE_METHODS[name],
            )  # fmt: skip
            pose = np.eye(4)
            pose[:3, :3], pose[:3, 3] = r, np.asarray(t).ravel()
        else:
            g_T_b = [_inverse(b) for b in b_T_g]
            _, _, r_z, t_z = cv2.calibrateRobotWorldHandEye(
                [c[:3, :3] for c in c_T_m], [c[:3, 3] for c in c_T_m],
                [g[:3, :3] for g in g_T_b], [g[:3, 3] for g in g_T_b],
                method=ROBOT_WORLD_METHODS[name],
            )  # fmt: skip
            c_T_g = np.eye(4)
            c_T_g[:3, :3], c_T_g[:3, 3] = r_z, np.asarray(t_z).ravel()
            pose = _inverse(c_T_g)
    except cv2.error as exc:
        return HandEyeFit(name, None, None, degenerate=f"OpenCV refused: {exc.msg or exc}")
    if not np.all(np.isfinite(pose)):
        return HandEyeFit(name, None, None, degenerate="OpenCV returned no finite pose")
    marker = np.mean([(b @ pose @ c)[:3, 3] for b, c in zip(b_T_g, c_T_m, strict=True)], axis=0)
    return _eih_fit(name, views, pose, marker)


# -------------------------------------------------------------------- all of them


def solve(
    views: Sequence[MarkerView],
    mount: str,
    *,
    methods: Sequence[str] | None = None,
    marker_offset: Sequence[float] = (0.0, 0.0, 0.0),
    guess: np.ndarray | None = None,
    marker_z: float | None = None,
) -> list[HandEyeFit]:
    """Every method's fit, best (least RMS residual) first.

    ``marker_offset``: the marker in the tool frame (eye-to-hand); ``guess``: the
    profile's camera pose (the starting point, needed eye-in-hand); ``marker_z``:
    the still marker's height (eye-in-hand). Raises :class:`DegenerateData` when no
    method can use the views, with the reason and the pose to fix.
    """
    if mount not in (EYE_TO_HAND, EYE_IN_HAND):
        raise ValueError(f"unknown camera mount {mount!r}")
    names = list(methods) if methods else (
        ["three_positions", "pnp", *HAND_EYE_METHODS, *ROBOT_WORLD_METHODS]
        if mount == EYE_TO_HAND
        else ["pnp", *HAND_EYE_METHODS, *ROBOT_WORLD_METHODS]
    )  # fmt: skip
    offset = np.asarray(marker_offset, dtype=float)
    fits: list[HandEyeFit] = []
    if names == ["three_positions"]:
        fits.append(e2h_three_positions(views, offset))
        return fits
    seen = seen_views(views, min(MIN_VIEWS[n] for n in names))
    check_spread(seen)
    turning = turning_axes(seen)
    for name in names:
        if name == "three_positions":
            continue  # needs its own three moves
        if len(seen) < MIN_VIEWS[name]:
            fits.append(HandEyeFit(name, None, None, degenerate=f"needs {MIN_VIEWS[name]} views"))
        elif name == "pnp":
            if mount == EYE_TO_HAND:
                fits.append(e2h_pnp(seen, offset, guess))
            elif guess is None:
                fits.append(
                    HandEyeFit(name, None, None, degenerate="needs the profile's camera pose")
                )
            else:
                fits.append(eih_pnp(seen, guess, marker_z))
        elif not hasattr(cv2, "calibrateHandEye"):
            fits.append(
                HandEyeFit(
                    name, None, None, degenerate=f"not in OpenCV {cv2.__version__}'s Python API"
                )
            )
        elif turning:
            fits.append(HandEyeFit(name, None, None, degenerate=turning))
        elif mount == EYE_TO_HAND:
            fits.append(e2h_opencv(seen, name))
        else:
            fits.append(eih_opencv(seen, name))
    fits.sort(key=lambda f: f.rms_mm)
    if not fits or fits[0].rms_mm == float("inf"):
        reasons = "; ".join(f"{f.method}: {f.degenerate or 'no fit'}" for f in fits)
        raise DegenerateData(f"no method could calibrate from these views ({reasons})")
    return fits


__all__ = [
    "HAND_EYE_METHODS",
    "MIN_VIEWS",
    "ROBOT_WORLD_METHODS",
    "DegenerateData",
    "HandEyeFit",
    "MarkerView",
    "check_spread",
    "check_three_moves",
    "lateral_residuals",
    "seen_views",
    "solve",
    "turning_axes",
]
