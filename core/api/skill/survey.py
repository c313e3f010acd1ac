"""The table points a search looks at, in order, from the profile's ``workcell.survey``.

A ring is swept back and forth in base-angle steps (Showers 2016, appendix B: 5
degrees, reversing at +/-100 degrees); a rectangle row by row, each row the other
way round; viewpoints in the order written, then back. Points are on the table
top (``workcell.table_z_mm``) unless a viewpoint gives its own z. mm and degrees.
"""

from __future__ import annotations

import math

import numpy as np

from armtree.config.workcell import Survey


def sweep_legs(start: float, lo: float, hi: float, step: float, sweeps: int) -> list[list[float]]:
    """Base angles (degrees) of a back-and-forth sweep from ``start`` within [lo, hi], leg by leg.

    First towards ``hi`` then back to ``lo`` and so on, ``sweeps`` legs in all
    (Showers 2016, appendix B: 5 degree steps, reversing at +/-100 degrees); the first
    leg begins with ``start`` itself. Every other leg begins with half a step, so
    its poses fall between those of the leg before: a marker that no pose of one
    leg shows whole (cut by the image's edge) is seen from new poses on the way
    back, not from the same ones again.
    """
    if step <= 0 or hi < lo:
        raise ValueError("a sweep needs step > 0 and range lo <= hi")
    angle = min(max(start, lo), hi)
    legs: list[list[float]] = []
    direction = 1.0
    for leg in range(max(1, sweeps)):
        out = [angle] if leg == 0 else []
        end = hi if direction > 0 else lo
        first = 0.5 * step if leg % 2 else step
        while (end - angle) * direction > 1e-9:
            angle = angle + direction * min(first, abs(end - angle))
            first = step
            out.append(angle)
        legs.append(out)
        direction = -direction
    return legs


def sweep_angles(start: float, lo: float, hi: float, step: float, sweeps: int) -> list[float]:
    """The angles of :func:`sweep_legs`, one list (degrees)."""
    return [a for leg in sweep_legs(start, lo, hi, step, sweeps) for a in leg]


def grid_points(survey: Survey) -> list[tuple[float, float]]:
    """A rectangle's grid, row by row (rows along x, each row the other way round)."""
    (x0, x1), (y0, y1), step = survey.x_mm, survey.y_mm, survey.step_mm
    xs = np.linspace(x0, x1, max(1, math.ceil((x1 - x0) / step - 1e-9) + 1))
    ys = np.linspace(y0, y1, max(1, math.ceil((y1 - y0) / step - 1e-9) + 1))
    out: list[tuple[float, float]] = []
    for row, y in enumerate(ys):
        for x in xs if row % 2 == 0 else xs[::-1]:
            out.append((float(x), float(y)))
    return out


def survey_points(
    survey: Survey, table_z: float, here: np.ndarray, sweeps: int
) -> list[np.ndarray]:
    """The table points (mm, base frame) to look at, ``sweeps`` legs, starting near ``here``.

    A ring starts at the base angle of ``here`` (the tool's position) and looks at
    each of its radii at every angle (outwards at one, inwards at the next); a
    rectangle's or the viewpoints' legs start at the point nearest ``here`` and
    go on in order, each later leg retracing the one before (a single viewpoint is
    looked at once per leg).
    """
    if survey.shape == "ring":
        lo, hi = survey.range_deg
        start = math.degrees(math.atan2(here[1], here[0]))
        radii = list(survey.radii_mm or (survey.radius_mm,))
        points = []
        for a in sweep_angles(start, lo, hi, survey.step_deg, sweeps):
            for r in radii:
                points.append(
                    np.array(
                        [r * math.cos(math.radians(a)), r * math.sin(math.radians(a)), table_z]
                    )
                )
            radii.reverse()  # out and back in at the next angle: the shortest way
        return points
    if survey.shape == "rectangle":
        flat = [np.array([x, y, table_z]) for x, y in grid_points(survey)]
    else:
        flat = [np.array([p[0], p[1], p[2] if len(p) > 2 else table_z]) for p in survey.points]
    first = int(np.argmin([np.linalg.norm(p[:2] - here[:2]) for p in flat]))
    leg = flat[first:] + flat[:first]
    out: list[np.ndarray] = []
    for n in range(max(1, sweeps)):
        part = leg if n % 2 == 0 else leg[::-1]
        # a later leg starts where the one before turned; one viewpoint is looked at once a leg
        out.extend(part[1:] if n > 0 and len(leg) > 1 else part)
    return out


__all__ = ["grid_points", "survey_points", "sweep_angles", "sweep_legs"]
