"""Where a seen marker is in the arm's base frame, and the small calibrations behind it.

Plugin-free maths shared by the skills. Units: millimetres for positions,
4x4 homogeneous matrices for poses, rotation vectors in radians (OpenCV's
Rodrigues form). Frame names follow Showers 2016: 0 the arm base, T the tool
centre, C the camera, A a marker.

* Eye-in-hand (camera on the tool): ``base_T_marker = base_T_tool @ tool_T_camera
  @ camera_T_marker`` (Showers 2016, eqs. 16 and 18 written with matrices).
* Eye-to-hand (fixed camera): ``base_T_marker = base_T_camera @ camera_T_marker``
  (Durovic 2017, step 2 of the visual-servoing loop).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from armtree.maths.motion.kinematics import KinematicModel

EYE_IN_HAND = "eye_in_hand"
EYE_TO_HAND = "eye_to_hand"


def rodrigues(rvec: np.ndarray) -> np.ndarray:
    """3x3 rotation matrix of a rotation vector (axis times angle, radians)."""
    r = np.asarray(rvec, dtype=float).reshape(3)
    theta = float(np.linalg.norm(r))
    if theta < 1e-12:
        return np.eye(3)
    k = r / theta
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(theta) * kx + (1.0 - np.cos(theta)) * (kx @ kx)


def transform(rvec: np.ndarray | None, tvec: np.ndarray) -> np.ndarray:
    """4x4 pose from a rotation vector (radians; None for identity) and a translation (mm)."""
    pose = np.eye(4)
    if rvec is not None:
        pose[:3, :3] = rodrigues(rvec)
    pose[:3, 3] = np.asarray(tvec, dtype=float).reshape(3)
    return pose


def camera_in_base(mount: str, extrinsics: np.ndarray, base_T_tool: np.ndarray) -> np.ndarray:
    """Camera pose in the base frame, 4x4 mm.

    ``extrinsics`` is the camera's pose in the tool frame for ``eye_in_hand``
    and in the base frame for ``eye_to_hand`` (as :class:`armtree.api.rig.Camera`
    documents); ``base_T_tool`` is the tool pose from the arm's joint readings.
    """
    extrinsics = np.asarray(extrinsics, dtype=float)
    if mount == EYE_IN_HAND:
        return np.asarray(base_T_tool, dtype=float) @ extrinsics
    if mount == EYE_TO_HAND:
        return extrinsics
    raise ValueError(f"unknown camera mount {mount!r} (eye_in_hand or eye_to_hand)")


def marker_in_base(
    base_T_camera: np.ndarray, rvec: np.ndarray | None, tvec: np.ndarray
) -> np.ndarray:
    """A marker's pose in the base frame from its camera-frame pose, 4x4 mm.

    Showers 2016, eq. 18 and the sum that follows it: P_0A = P_0T + R_0T R_TC (P_CA - P_CT);
    with matrices this is base_T_camera @ camera_T_marker.
    """
    return np.asarray(base_T_camera, dtype=float) @ transform(rvec, tvec)


def tool_to_marker(
    base_T_tool: np.ndarray, tool_T_camera: np.ndarray, p_ca: np.ndarray
) -> np.ndarray:
    """(P_TA)_0: the move in base axes that brings the tool centre onto the marker, mm.

    Showers 2016, eq. 18: (P_TA)_0 = R_0T R_TC (P_CA - P_CT), where P_CT is the tool
    centre seen from the camera, i.e. ``inverse(tool_T_camera)``'s translation
    expressed in camera axes.
    """
    base_T_tool = np.asarray(base_T_tool, dtype=float)
    tool_T_camera = np.asarray(tool_T_camera, dtype=float)
    r_0t, r_tc = base_T_tool[:3, :3], tool_T_camera[:3, :3]
    p_ct = -r_tc.T @ tool_T_camera[:3, 3]
    return r_0t @ r_tc @ (np.asarray(p_ca, dtype=float).reshape(3) - p_ct)


def along_ray_to_height(camera_position: np.ndarray, point: np.ndarray, z: float) -> np.ndarray:
    """Where the ray from the camera through ``point`` meets the height ``z`` (mm, base frame).

    A marker's distance is the least accurate part of its measured pose (Durovic 2017,
    Conclusion: "the main error source ... is inaccurate determination of the
    marker distance"); when its height is known otherwise, its direction from the
    camera is kept and its distance replaced. ``point`` is returned unchanged
    when the ray runs (nearly) level.
    """
    c = np.asarray(camera_position, dtype=float).reshape(3)
    p = np.asarray(point, dtype=float).reshape(3)
    dz = p[2] - c[2]
    if abs(dz) < 1e-6:
        return p.copy()
    return c + (p - c) * ((float(z) - c[2]) / dz)


def estimate_camera_offset(
    p_ca: Sequence[np.ndarray],
    base_T_tools: Sequence[np.ndarray],
    p_0a: Sequence[np.ndarray],
    r_tc: np.ndarray,
) -> np.ndarray:
    """P_CT (mm, camera axes) averaged over touch tests, Showers 2016 eq. 17.

    For each test k the camera saw the marker at ``p_ca[k]`` while the tool was at
    ``base_T_tools[k]``; the marker's base position ``p_0a[k]`` was measured by
    touching it. eq. 17: P_CT = P_CA + R_CT R_T0 (P_0T - P_0A), with
    R_CT = ``r_tc``\\ :sup:`T` the camera-to-tool rotation of the mount.
    """
    if not (len(p_ca) == len(base_T_tools) == len(p_0a)) or len(p_ca) == 0:
        raise ValueError("estimate_camera_offset needs the same number (>= 1) of each measurement")
    r_ct = np.asarray(r_tc, dtype=float).T
    out = []
    for pca, t0t, p0a in zip(p_ca, base_T_tools, p_0a, strict=True):
        t0t = np.asarray(t0t, dtype=float)
        r_t0 = t0t[:3, :3].T
        out.append(
            np.asarray(pca, dtype=float).reshape(3)
            + r_ct @ r_t0 @ (t0t[:3, 3] - np.asarray(p0a, dtype=float).reshape(3))
        )
    return np.mean(out, axis=0)


def eye_to_hand_from_three_positions(
    c_t_m: Sequence[np.ndarray], r_t_g0: np.ndarray, g_t_m: np.ndarray
) -> np.ndarray:
    """camera_T_base (4x4 mm) from a tool marker seen at three arm positions, Durovic 2017 eqs. 1-7.

    ``c_t_m[k]`` is the marker in the camera frame at position k: position 1 is
    position 0 moved along the base x-axis, position 2 is position 1 moved along
    base y at the same height. ``r_t_g0`` is the tool position at 0 (base frame,
    tool x-axis parallel to base x) and ``g_t_m`` the marker in the tool frame.
    """
    t0, t1, t2 = (np.asarray(t, dtype=float).reshape(3) for t in c_t_m)
    x = (t1 - t0) / np.linalg.norm(t1 - t0)  # eq. 1
    b = t2 - t1  # eq. 3
    z = np.cross(x, b)
    z /= np.linalg.norm(z)  # eq. 2
    y = np.cross(z, x)  # eq. 5
    c_r_r = np.column_stack([x, y, z])  # eq. 4
    c_t_r = t0 - c_r_r @ (np.asarray(g_t_m, dtype=float) + np.asarray(r_t_g0, dtype=float))  # eq. 7
    pose = np.eye(4)
    pose[:3, :3] = c_r_r
    pose[:3, 3] = c_t_r
    return pose


@dataclass(frozen=True)
class LinearCorrection:
    """Per-axis linear map x' = a_x x + b_x, y' = a_y y + b_y (Durovic 2017, eq. 8); mm."""

    ax: float = 1.0
    bx: float = 0.0
    ay: float = 1.0
    by: float = 0.0

    @classmethod
    def fit(cls, measured: np.ndarray, reference: np.ndarray) -> LinearCorrection:
        """Least squares of Durovic 2017's J_x and J_y over ``(N, >=2)`` measured and reference points."""
        m = np.asarray(measured, dtype=float)
        r = np.asarray(reference, dtype=float)
        if m.shape[0] < 2 or m.shape != r.shape:
            raise ValueError("a linear correction needs at least two matching points")
        ax, bx = np.polyfit(m[:, 0], r[:, 0], 1)
        ay, by = np.polyfit(m[:, 1], r[:, 1], 1)
        return cls(float(ax), float(bx), float(ay), float(by))

    def apply(self, xyz: np.ndarray) -> np.ndarray:
        """Corrected copy of a position (or ``(N, 3)`` positions); z unchanged."""
        out = np.array(xyz, dtype=float)
        out[..., 0] = self.ax * out[..., 0] + self.bx
        out[..., 1] = self.ay * out[..., 1] + self.by
        return out

    def inverse(self, xyz: np.ndarray) -> np.ndarray:
        """The position (or positions) that :meth:`apply` maps onto ``xyz``; z unchanged."""
        out = np.array(xyz, dtype=float)
        out[..., 0] = (out[..., 0] - self.bx) / self.ax
        out[..., 1] = (out[..., 1] - self.by) / self.ay
        return out


def tool_for_camera_over(
    model: KinematicModel,
    point: np.ndarray,
    height: float,
    tool_T_camera: np.ndarray,
    near: np.ndarray | None = None,
    iterations: int = 4,
    rotation_at: Callable[[np.ndarray], np.ndarray] | None = None,
) -> np.ndarray:
    """Tool position (mm) that puts an eye-in-hand camera ``height`` mm above ``point``.

    The camera's offset turns with the tool, and the tool's orientation depends
    on where it is, so the position is found by fixed-point iteration.
    ``rotation_at(xyz)`` gives the tool's 3x3 orientation at a position; by
    default the model's forward kinematics of its inverse kinematics, which
    raises :class:`~armtree.errors.Unreachable` when a step leaves the workspace.
    """
    if rotation_at is None:

        def rotation_at(xyz: np.ndarray) -> np.ndarray:
            return model.fk(model.ik(xyz, near=near))[:3, :3]

    want = np.asarray(point, dtype=float).reshape(3) + np.array([0.0, 0.0, height])
    offset = np.asarray(tool_T_camera, dtype=float)[:3, 3]
    tool = want - offset
    for _ in range(iterations):
        tool = want - rotation_at(tool) @ offset
    return tool
