"""The predicates of ``expect:``: each judges one kind of claim about the world.

An entry names one predicate by its key (``on``, ``in``, ``at``, ``held``,
``collisions``, ``missed_steps``, ``parked``, ``tool_within_mm``, or one a plugin registers through
``armtree_predicates``) and, for predicates about objects, what it is about:
``object: NAME_OR_ROLE`` (at least one such body must pass) or
``objects: NAME_OR_ROLE`` (every such body must pass; a list of names works too).

A predicate checks its entry against the nominal world while the tree loads
(:meth:`Predicate.check`) and judges the world at the end of a run
(:meth:`Predicate.judge`), once per object, or once for the whole world when it
takes no object. Millimetres.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from armtree.errors import Mark, did_you_mean

from .truth import DUCKYBOTS, MARKERS, TOOL, WorldObject, WorldTruth

NAME_SCHEMA: dict[str, Any] = {"type": "string", "description": "a body's name or a tag role"}


@dataclass(frozen=True)
class Expectation:
    """One entry of ``expect:``: the predicate's key and value, its subject and options.

    ``subject`` holds the names or tag roles given with ``object:`` /
    ``objects:`` (empty for predicates about the whole world); ``every`` is True
    for ``objects:``. ``options`` has the predicate's defaults filled in.
    """

    predicate: str
    value: Any
    subject: tuple[str, ...] = ()
    every: bool = False
    options: Mapping[str, Any] = field(default_factory=dict)
    written: Mapping[str, Any] = field(default_factory=dict)
    mark: Mark | None = None

    def text(self, predicates: Mapping[str, Predicate] | None = None) -> str:
        """The claim in words: ``"ducky on duckybot"``, ``"every trash in garbage_bin"``."""
        predicate = (predicates or BUILTIN_PREDICATES).get(self.predicate)
        claim = predicate.describe(self) if predicate else f"{self.predicate}: {self.value}"
        if not self.subject:
            return claim
        who = ", ".join(self.subject)
        return f"{'every ' if self.every else ''}{who} {claim}"


@dataclass(frozen=True)
class Judgement:
    """One predicate's answer: whether it holds, the value measured and a short text."""

    passed: bool
    measured: Any
    detail: str


class Predicate:
    """Base class of an ``expect:`` predicate; subclasses override what differs.

    ``SUBJECT``: ``"required"`` (the entry must name ``object:`` or ``objects:``),
    ``"optional"`` or ``"none"``. ``VALUE`` is the JSON Schema of the predicate
    key's value and ``OPTIONS`` that of each further key the entry may have
    (with their defaults in ``DEFAULTS``); the loader rejects other keys.
    """

    SUBJECT: ClassVar[str] = "required"
    VALUE: ClassVar[dict[str, Any]] = {}
    OPTIONS: ClassVar[dict[str, dict[str, Any]]] = {}
    DEFAULTS: ClassVar[dict[str, Any]] = {}

    def check(self, entry: Expectation, world: WorldTruth) -> list[tuple[str, str]]:
        """Problems with ``entry`` in the nominal ``world``, as ``(key, message)``; [] if none.

        ``world.complete`` is False when only the names of tag roles and places
        are known (a real rig): then check names, not kinds.
        """
        return []

    def describe(self, entry: Expectation) -> str:
        """The claim in words, without its subject: ``"on duckybot"``."""
        return f"{entry.predicate} {entry.value}"

    def judge(self, entry: Expectation, obj: WorldObject | None, world: WorldTruth) -> Judgement:
        """Judge the claim for one object (``obj``), or for the world when it takes none."""
        raise NotImplementedError


def _targets(world: WorldTruth, ref: str) -> set[str]:
    return {o.name for o in world.select(ref)}


def _unknown(world: WorldTruth, ref: Any, what: str, places: bool = False) -> str | None:
    """A message when ``ref`` is not a name this world knows, else None."""
    if not isinstance(ref, str) or not ref:
        return f"expected the name of {what}, got {ref!r}"
    if world.knows(ref) or (places and ref in world.places):
        return None
    options = world.names() + (sorted(world.places) if places else [])
    return f"no {what} {ref!r} in this world{did_you_mean(ref, options)}"


class On(Predicate):
    """``on: X``: the object rests on X (a body or tag role), directly or on a stack on it."""

    VALUE = NAME_SCHEMA

    def check(self, entry: Expectation, world: WorldTruth) -> list[tuple[str, str]]:
        problem = _unknown(world, entry.value, "body or tag role", places=not world.complete)
        return [("on", problem)] if problem else []

    def describe(self, entry: Expectation) -> str:
        return f"on {entry.value}"

    def judge(self, entry: Expectation, obj: WorldObject | None, world: WorldTruth) -> Judgement:
        assert obj is not None
        chain = world.supports(obj)
        passed = bool(_targets(world, entry.value) & set(chain))
        where = "held" if obj.held else (obj.on or "falling")
        return Judgement(passed, where, f"{obj.name} on {where}")


class In(Predicate):
    """``in: X``: the object lies inside the container X (a bin)."""

    VALUE = NAME_SCHEMA

    def check(self, entry: Expectation, world: WorldTruth) -> list[tuple[str, str]]:
        problem = _unknown(world, entry.value, "container", places=not world.complete)
        if problem:
            return [("in", problem)]
        if world.complete and not any(o.container for o in world.select(entry.value)):
            return [("in", f"{entry.value!r} is not a container (a bin) in this world")]
        return []

    def describe(self, entry: Expectation) -> str:
        return f"in {entry.value}"

    def judge(self, entry: Expectation, obj: WorldObject | None, world: WorldTruth) -> Judgement:
        assert obj is not None
        passed = obj.inside is not None and obj.inside in _targets(world, entry.value)
        where = f"in {obj.inside}" if obj.inside else ("held" if obj.held else f"on {obj.on}")
        return Judgement(passed, obj.inside, f"{obj.name} {where}")


class At(Predicate):
    """``at: P`` (``within_mm: T``): the object's centre is within T mm of P in the table plane.

    P is a place of the profile or a body (the nearest of a role's bodies). Where P
    names a container (a bin), the object is at it when it lies inside it, wherever
    in it: a bin spreads its drops across its inside, so no one tolerance fits every bin.
    """

    VALUE = NAME_SCHEMA
    OPTIONS = {
        "within_mm": {"type": "number", "exclusiveMinimum": 0, "description": "tolerance (mm)"}
    }
    DEFAULTS = {"within_mm": 15.0}

    def check(self, entry: Expectation, world: WorldTruth) -> list[tuple[str, str]]:
        problem = _unknown(world, entry.value, "place or body", places=True)
        out = [("at", problem)] if problem else []
        tol = entry.options.get("within_mm")
        # a NaN or infinite tolerance would pass anything
        if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not 0 < tol < math.inf:
            out.append(
                ("within_mm", f"within_mm: expected a finite tolerance in mm > 0, got {tol!r}")
            )
        return out

    def describe(self, entry: Expectation) -> str:
        return f"at {entry.value} within {entry.options['within_mm']:g} mm"

    def judge(self, entry: Expectation, obj: WorldObject | None, world: WorldTruth) -> Judgement:
        assert obj is not None
        bins = {o.name for o in world.select(entry.value) if o.container}
        if bins:
            where = f"in {obj.inside}" if obj.inside else ("held" if obj.held else f"on {obj.on}")
            return Judgement(obj.inside in bins, obj.inside, f"{obj.name} {where}")
        points = [o.position for o in world.select(entry.value) if o.name != obj.name]
        if entry.value in world.places:
            points.append(world.places[entry.value])
        if not points:
            return Judgement(False, None, f"no {entry.value} in this world")
        distance = min(obj.distance_xy(p) for p in points)
        passed = distance <= float(entry.options["within_mm"])
        return Judgement(passed, round(distance, 1), f"{obj.name} {distance:.1f} mm away")


class Held(Predicate):
    """``held``: with an object, ``true``/``false`` (is it in the tool?); without,
    what the tool holds at the end: ``nothing`` or a body or tag role."""

    SUBJECT = "optional"
    VALUE = {"anyOf": [{"type": "boolean"}, {"type": "string"}]}

    def check(self, entry: Expectation, world: WorldTruth) -> list[tuple[str, str]]:
        if entry.subject:
            if not isinstance(entry.value, bool):
                return [("held", f"with an object, held is true or false, got {entry.value!r}")]
            return []
        if entry.value == "nothing":
            return []
        problem = _unknown(world, entry.value, "body or tag role")
        return [("held", f"{problem}; or write held: nothing")] if problem else []

    def describe(self, entry: Expectation) -> str:
        if entry.subject:
            return "held" if entry.value else "not held"
        return f"held: {entry.value}"

    def judge(self, entry: Expectation, obj: WorldObject | None, world: WorldTruth) -> Judgement:
        if obj is not None:
            passed = obj.held == bool(entry.value)
            return Judgement(passed, obj.held, f"{obj.name} {'held' if obj.held else 'not held'}")
        holding = world.held or "nothing"
        if entry.value == "nothing":
            passed = world.held is None
        else:
            passed = world.held is not None and world.held in _targets(world, entry.value)
        return Judgement(passed, holding, f"the tool holds {holding}")


class AtMost(Predicate):
    """``KEY: N``: at most N events of one kind happened in the run (collisions, missed steps)."""

    SUBJECT = "none"
    VALUE = {"type": "integer", "minimum": 0, "description": "the most allowed"}
    #: Which list of :class:`WorldTruth` holds the events, what one and several are
    #: called, and one event in a few words (``str.format`` of its fields).
    EVENTS: ClassVar[str] = ""
    ONE: ClassVar[str] = ""
    NOUN: ClassVar[str] = ""
    SHOW: ClassVar[str] = ""

    def check(self, entry: Expectation, world: WorldTruth) -> list[tuple[str, str]]:
        value = entry.value
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            return [
                (entry.predicate, f"expected the most allowed (an integer >= 0), got {value!r}")
            ]
        return []

    def describe(self, entry: Expectation) -> str:
        return f"{self.NOUN} <= {entry.value}"

    def judge(self, entry: Expectation, obj: WorldObject | None, world: WorldTruth) -> Judgement:
        events = getattr(world, self.EVENTS)
        count = len(events)
        detail = f"{count} {self.NOUN if count != 1 else self.ONE}"
        if events:
            detail += ": " + "; ".join(self.SHOW.format(**e) for e in events[:3])
            detail += f"; and {count - 3} more" if count > 3 else ""
        return Judgement(count <= entry.value, count, detail)


class Collisions(AtMost):
    """``collisions: N``: at most N collisions of the arm (or what it holds) with bodies."""

    EVENTS, ONE, NOUN = "collisions", "collision", "collisions"
    SHOW = "{link} hit {other} {depth_mm:.1f} mm at t={time:.2f} s"


class MissedSteps(AtMost):
    """``missed_steps: N``: at most N missed steps (joint slips the firmware did not see)."""

    EVENTS, ONE, NOUN = "missed_steps", "missed step", "missed steps"
    SHOW = "joint {joint} by {amount:.2f} at t={time:.2f} s"


def _finite(value: Any) -> bool:
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
        if not _finite(entry.value) or entry.value <= 0:
            out.append(("tool_within_mm", f"expected a distance in mm > 0, got {entry.value!r}"))
        if not _finite(entry.options.get("above_mm")):
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


#: The vocabulary armtree itself provides; plugins add theirs through armtree_predicates.
BUILTIN_PREDICATES: dict[str, Predicate] = {
    "on": On(),
    "in": In(),
    "at": At(),
    "held": Held(),
    "collisions": Collisions(),
    "missed_steps": MissedSteps(),
    "parked": Parked(),
    "tool_within_mm": ToolWithin(),
}
