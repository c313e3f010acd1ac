"""The measuring device on real hardware: the operator, asked at the console.

Durovic 2017 read a laser spot on millimetre paper and Showers 2016 a pencil tip on graph
paper; here the operator types what they read. Each question is printed once and
the answer read on a thread of its own, so ticks go on while the person measures.
"""

from __future__ import annotations

import sys
import threading
from typing import Any, TextIO

import numpy as np

from armtree.api.measuring import Measurement, MeasuringDevice


class OperatorMeasuringDevice(MeasuringDevice):
    """Asks the operator to measure and type ``x, y, z`` in mm (base frame)."""

    description = "the operator, reading millimetre paper (typed at the console)"

    def __init__(self, stdin: TextIO | None = None, stdout: TextIO | None = None) -> None:
        self.stdin = stdin or sys.stdin
        self.stdout = stdout or sys.stderr

    def _ask(self, what: str, question: str, numbers: bool = True) -> Measurement:
        out = Measurement(what)

        def read() -> None:
            print(question, file=self.stdout, flush=True)
            line = self.stdin.readline()
            if not line:
                out.finish(error="no answer (the input ended)")
                return
            if not numbers:
                out.finish(np.zeros(3))
                return
            try:
                values = [float(v) for v in line.replace(",", " ").split()]
            except ValueError:
                out.finish(error=f"not numbers: {line.strip()!r}")
                return
            if len(values) not in (2, 3):
                out.finish(error=f"expected x y [z] in mm, got {line.strip()!r}")
                return
            out.finish(values + [float("nan")] * (3 - len(values)))

        threading.Thread(target=read, name=f"operator: {what}", daemon=True).start()
        return out

    def tool_position(self) -> Measurement:
        return self._ask(
            "tool position",
            "measure where the tool points (laser spot / pencil tip); type x y [z] in mm:",
        )

    def marker_position(self, marker_id: int) -> Measurement:
        return self._ask(
            f"marker {marker_id}", f"measure the centre of marker {marker_id}; type x y z in mm:"
        )

    def place_marker(self, marker_id: int, xy: Any) -> Measurement:
        x, y = (float(v) for v in np.asarray(xy, dtype=float)[:2])
        return self._ask(
            f"place marker {marker_id}",
            f"put marker {marker_id} at about ({x:.0f}, {y:.0f}) mm on the table, then press Enter",
            numbers=False,
        )


__all__ = ["OperatorMeasuringDevice"]
