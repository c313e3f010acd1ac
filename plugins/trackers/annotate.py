"""Drawing detections on an image: outlines, the printed top-left corner, ids and pose axes."""

from __future__ import annotations

import cv2
import numpy as np

from armtree.api.rig import Detection


def annotate(
    image: np.ndarray,
    detections: list[Detection],
    camera_matrix: np.ndarray | None = None,
    distortion: np.ndarray | None = None,
) -> np.ndarray:
    """A BGR copy of ``image`` with every detection drawn.

    Green outline (orange when ambiguous), a filled dot on corner 0 (the
    marker's top-left as printed), the id and role, and the marker's x (red),
    y (green) and z (blue) axes half a side long when it has a pose.
    """
    out = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    scale = max(1, round(max(out.shape[:2]) / 640))
    for det in detections:
        corners = np.asarray(det.corners, dtype=np.float32).reshape(4, 2)
        colour = (0, 165, 255) if det.ambiguous else (0, 200, 0)
        cv2.polylines(out, [np.round(corners).astype(np.int32)], True, colour, scale, cv2.LINE_AA)
        cv2.circle(out, tuple(int(v) for v in np.round(corners[0])), 3 * scale, (0, 0, 255), -1)
        label = (
            f"{det.id}"
            + ("" if det.role == "unknown" else f" {det.role}")
            + ("?" if det.ambiguous else "")
        )
        org = tuple(int(v) for v in np.round(corners.min(axis=0) - [0, 6 * scale]))
        cv2.putText(
            out, label, org, cv2.FONT_HERSHEY_SIMPLEX, 0.5 * scale, colour, scale, cv2.LINE_AA
        )
        if (
            det.rvec is not None
            and det.tvec is not None
            and camera_matrix is not None
            and det.size_mm
        ):
            dist = np.zeros(5) if distortion is None else np.asarray(distortion, dtype=float)
            cv2.drawFrameAxes(
                out,
                np.asarray(camera_matrix, dtype=float),
                dist,
                np.asarray(det.rvec, dtype=float),
                np.asarray(det.tvec, dtype=float),
                det.size_mm / 2,
                2 * scale,
            )
    return out
