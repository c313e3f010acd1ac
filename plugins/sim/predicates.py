"""``expect:`` predicates only the simulated world can judge: a Duckybot parked, the tool near a marker.

The world hands what they read to the runtime in ``WorldTruth.extra`` (see
:func:`~.truth.world_truth`): ``duckybots`` (each one's ``phase`` and ``pose``),
``tool_mm`` (the tool centre, base frame) and ``markers`` (each marked body's
marker centre). Millimetres, base frame.
"""

from __future__ import annotations

import math
from typing import Any

from armtree.outcomes import Judgement, Predicate, WorldObject, WorldTruth

#: ``WorldTruth.extra`` keys the world fills for these predicates.
DUCKYBOTS, TOOL, MARKERS = "duckybots", "tool_mm", "markers"


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


class Parked(Predicate):
    """``parked: true``: a Duckybot has stopped at a parking pose of its route and waits
    there; any other body is at rest (neither held nor falling). ``false``: the opposite."""

    VALUE = {"type": "boolean", "description": "the Duckybot waits at a parking pose"}

    def check(self, entry: Any, world: WorldTruth) -> list[tuple[str, str]]:
        if not isinstance(entry.value, bool):
            return [("parked", f"expected true or false, got {entry.value!r}")]
        return []

    def describe(self, entry: Any) -> str:
        return "parked" if entry.value else "not parked"

    def judge(self, entry: Any, obj: WorldObject | None, world: WorldTruth) -> Judgement:
        assert obj is not None
        bot = (world.extra.get(DUCKYBOTS) or {}).get(obj.name)
        if bot is None:
            rest = "held" if obj.held else ("at rest" if obj.on is not None else "falling")
            passed = (rest == "at rest") == bool(entry.value)
            return Judgement(passed, rest, f"{obj.name} {rest}")
        phase = str(bot["phase"])
        x, y, heading = bot["pose"]
        passed = (phase == "parked") == bool(entry.value)
        return Judgement(
            passed, phase, f"{obj.name} {phase} at [{x:.0f}, {y:.0f}] mm, {heading:.0f} deg"
        )


class ToolWithin(Predicate):
    """``tool_within_mm: N`` (``above_mm: H``, default 0): the tool centre ends within N mm
    of the point H mm above the object's marker centre."""

    VALUE = {"type": "number", "exclusiveMinimum": 0, "description": "the farthest allowed (mm)"}
    OPTIONS = {
        "above_mm": {
            # a tree's {param} is substituted before the entry is read
            "anyOf": [{"type": "number"}, {"type": "string", "pattern": r"^\{[A-Za-z_]\w*\}$"}],
            "description": "height over the marker (mm)",
        }
    }
    DEFAULTS = {"above_mm": 0.0}

    def check(self, entry: Any, world: WorldTruth) -> list[tuple[str, str]]:
        out = []
        if not _number(entry.value) or entry.value <= 0:
            out.append(("tool_within_mm", f"expected a distance in mm > 0, got {entry.value!r}"))
        if not _number(entry.options.get("above_mm")):
            out.append(("above_mm", f"expected a height in mm, got {entry.options['above_mm']!r}"))
        return out

    def describe(self, entry: Any) -> str:
        above = float(entry.options["above_mm"])
        where = f"{above:g} mm above its marker" if above else "its marker"
        return f"tool within {entry.value:g} mm of {where}"

    def judge(self, entry: Any, obj: WorldObject | None, world: WorldTruth) -> Judgement:
        assert obj is not None
        tool = world.extra.get(TOOL)
        marker = (world.extra.get(MARKERS) or {}).get(obj.name)
        if tool is None or marker is None:
            what = "no tool" if tool is None else f"{obj.name} carries no marker"
            return Judgement(False, None, what)
        goal = (marker[0], marker[1], marker[2] + float(entry.options["above_mm"]))
        distance = math.dist(tool, goal)
        return Judgement(
            distance <= float(entry.value),
            round(distance, 2),
            f"the tool {distance:.1f} mm from [{goal[0]:.0f}, {goal[1]:.0f}, {goal[2]:.0f}] mm",
        )


#: What the simulation registers through ``armtree_predicates``.
SIM_PREDICATES: dict[str, Predicate] = {"parked": Parked(), "tool_within_mm": ToolWithin()}

__all__ = ["SIM_PREDICATES", "Parked", "ToolWithin"]
