"""What the built-in cameras share: profile keys, intrinsics per frame, mounting."""

from __future__ import annotations

from typing import Any

import numpy as np

from armtree.api.clock import Clock
from armtree.api.imaging import (
    IntrinsicsBySize,
    extrinsics_from,
    intrinsics_from_config,
)
from armtree.api.rig import Camera, Frame, RigContext
from armtree.config.component_config import check_config
from armtree.config.params import Param


class FrameSourceCamera(Camera):
    """A camera that stamps each image with the run's time and the intrinsics for its size."""

    def __init__(
        self,
        name: str,
        clock: Clock,
        intrinsics: IntrinsicsBySize,
        mount: str = "eye_to_hand",
        extrinsics: np.ndarray | None = None,
    ) -> None:
        self.name = name
        self.clock = clock
        self.intrinsics = intrinsics
        self.mount = mount
        self.extrinsics = np.eye(4) if extrinsics is None else extrinsics
        self._index = 0

    def make_frame(self, image: np.ndarray, timestamp: float | None = None) -> Frame:
        """A :class:`Frame` of ``image`` stamped now (or at ``timestamp`` seconds)."""
        h, w = image.shape[:2]
        intr = self.intrinsics.get(w, h)
        frame = Frame(
            image=image,
            timestamp=self.clock.now() if timestamp is None else float(timestamp),
            camera_matrix=intr.camera_matrix,
            distortion=intr.distortion,
            index=self._index,
        )
        self._index += 1
        return frame


def camera_config(
    config: dict[str, Any], context: RigContext, params: tuple[Param, ...]
) -> tuple[dict[str, Any], IntrinsicsBySize, np.ndarray, Any]:
    """Checked values, intrinsics and extrinsics of a camera section, and where it was written."""
    where = context.profile
    values = check_config(config, params, "camera", where)
    intr = IntrinsicsBySize(intrinsics_from_config(values, where))
    return values, intr, extrinsics_from(values["extrinsics"], where), where


__all__ = ["FrameSourceCamera", "camera_config"]
