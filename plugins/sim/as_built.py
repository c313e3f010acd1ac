"""How the simulated rig really is, where the profile says what it should be; and the
simulated measuring device that reads it.

A real rig differs from its profile: the camera is not quite where the stand's
drawing puts it, the pencil sits 48 mm out where the suction cup sat at 55 (Showers
2016). Calibration exists to find those differences, so the simulation can have
them (``world.as_built``)::

    world:
      as_built:
        camera: {offset_mm: [4, -3, 6], rotation_deg: [0.8, -0.5, 1.2]}
        arm: {tool_offset_mm: 48, joint_offsets_deg: [0, 1.2, -2.5]}
      reference: {noise_mm: 0.1}

``camera``: the camera really stands ``offset_mm`` from the profile's position (in
the base frame eye-to-hand, the tool frame eye-in-hand) and is turned by
``rotation_deg`` (roll, pitch, yaw about its own axes); the profile's pose, or a
calibrated ``camera.extrinsics``, is what the skills believe. ``arm``: keys of the
profile's arm type (its own parameters) the real arm has instead; the world moves
the arm's true joints through that model. Skills never see any of it.

``reference``: the :class:`SimMeasuringDevice` the sim hands to ``rig.reference``:
the simulator's truth plus a Gaussian reading error of ``noise_mm`` per axis (Showers
2016's repeated graph-paper readings differed by 0.25-0.61 mm).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from armtree.api.measuring import Measurement, MeasuringDevice

from .geometry import rpy_matrix

#: The reading error of the simulated measuring device, per axis (mm), by default.
DEFAULT_NOISE_MM = 0.1


@dataclass(frozen=True)
class AsBuilt:
    """``world.as_built``: the camera's pose error and the real arm's keys."""

    camera_offset_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    camera_rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    arm: dict[str, Any] = field(default_factory=dict)
    reference_noise_mm: float = DEFAULT_NOISE_MM

    def camera(self, nominal: np.ndarray) -> np.ndarray:
        """The camera's true pose (4x4 mm) for the profile's ``nominal`` one."""
        true = np.array(nominal, dtype=float)
        true[:3, :3] = true[:3, :3] @ rpy_matrix(*self.camera_rotation_deg)[:3, :3]
        true[:3, 3] += np.asarray(self.camera_offset_mm, dtype=float)
        return true


class SimMeasuringDevice(MeasuringDevice):
    """The simulation's measuring device: the world's truth plus a seeded reading error.

    It stands in for the person with millimetre paper and a ruler of the seeds;
    everything it returns is ground truth of the simulator, and reports say so.
    """

    def __init__(self, world: Any, noise_mm: float, seed: int = 0) -> None:
        self._world = world
        self.noise = float(noise_mm)
        self.rng = np.random.default_rng([int(seed), 4004])
        self.description = (
            "simulated measuring device: the simulator's ground truth plus a "
            f"{self.noise:g} mm (sd per axis) reading error, standing in for a person "
            "with millimetre paper"
        )

    def _read(self, what: str, value: np.ndarray | None, error: str | None = None) -> Measurement:
        out = Measurement(what)
        if value is None:
            return out.finish(error=error or f"{what}: nothing to measure")
        return out.finish(np.asarray(value, dtype=float) + self.rng.normal(0.0, self.noise, 3))

    def tool_position(self) -> Measurement:
        """The tool centre's true position plus the reading error."""
        with self._world.lock:
            arm = self._world.arm
            tip = None if arm is None else arm.tool_pose[:3, 3].copy()
        return self._read("tool position", tip, "the simulated world has no arm")

    def marker_position(self, marker_id: int) -> Measurement:
        """The true centre of the body's (or tool's) marker ``marker_id`` plus the reading error."""
        with self._world.lock:
            for body in self._world.bodies.values():
                if body.marker is not None and body.marker.id == marker_id:
                    return self._read(f"marker {marker_id}", body.top_pose()[:3, 3].copy())
        return self._read(
            f"marker {marker_id}", None, f"no marker {marker_id} in the simulated world"
        )

    def place_marker(self, marker_id: int, xy: np.ndarray) -> Measurement:
        """Move the body carrying marker ``marker_id`` to ``xy`` (mm), as a person would."""
        with self._world.lock:
            for body in self._world.bodies.values():
                if body.marker is not None and body.marker.id == marker_id:
                    body.pose[:2, 3] = np.asarray(xy, dtype=float)[:2]
                    self._world.version += 1
                    return Measurement(f"place marker {marker_id}").finish(body.pose[:3, 3].copy())
        return Measurement(f"place marker {marker_id}").finish(
            error=f"no marker {marker_id} in the simulated world"
        )


__all__ = ["DEFAULT_NOISE_MM", "AsBuilt", "SimMeasuringDevice"]
