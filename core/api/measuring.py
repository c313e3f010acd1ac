"""A measuring device outside the arm: the ground truth of calibration and accuracy experiments.

The source documents measured by hand: Durovic 2017 read a laser pointer's spot on millimetre
paper (Tables I-III) and placed its target marker by hand (experiment 2); Showers
2016 put a pencil tip on graph paper (model validation) and touched markers with
the tool (touch tests, eq. 17). A :class:`MeasuringDevice` is that person with
their paper, handed to behaviours as ``rig.reference``: on hardware it asks the
operator at the console, in the simulation it is a simulated device of the sim
plugin that reads the simulator's truth plus a reading error and says so in
:attr:`MeasuringDevice.description`. Skills never use it to decide anything a
run does; calibrations and experiments record what it measures.

Every call returns at once with a :class:`Measurement` to poll. Units: mm, base frame.
"""

from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from typing import Any

import numpy as np


class Measurement:
    """One measurement under way: :attr:`done`, then :attr:`value` (mm) or :attr:`error`."""

    def __init__(self, what: str) -> None:
        self.what = what
        self.value: np.ndarray | None = None
        self.error: str | None = None
        self._done = threading.Event()

    @property
    def done(self) -> bool:
        """True once the value (or the reason there is none) is in."""
        return self._done.is_set()

    def finish(self, value: Any = None, error: str | None = None) -> Measurement:
        """Device side: record the value (mm) or why there is none; returns self."""
        if not self.done:
            self.value = None if value is None else np.asarray(value, dtype=float)
            self.error = error
            self._done.set()
        return self

    def __repr__(self) -> str:
        if not self.done:
            state = "pending"
        elif self.error or self.value is None:
            state = self.error or "no value"
        else:
            state = np.round(self.value, 2).tolist()
        return f"<Measurement {self.what}: {state}>"


class MeasuringDevice(ABC):
    """Measures the rig from outside, as the source documents' people did (see the module)."""

    #: What the device is, for reports: "operator with millimetre paper", "simulated ...".
    description: str = ""

    @abstractmethod
    def tool_position(self) -> Measurement:
        """Where the tool centre is, mm in the base frame (a laser spot or pencil tip on paper)."""

    @abstractmethod
    def marker_position(self, marker_id: int) -> Measurement:
        """Where a marker's centre is, mm in the base frame (touching it, Showers 2016)."""

    @abstractmethod
    def place_marker(self, marker_id: int, xy: np.ndarray) -> Measurement:
        """Have a loose marker put near ``xy`` (mm) on the table; its value is where it was
        put as far as the device knows (the operator's word, or None)."""


__all__ = ["Measurement", "MeasuringDevice"]
