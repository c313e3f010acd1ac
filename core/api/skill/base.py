"""The base of every skill: a generator of actions run one tick at a time.

A skill writes its procedure as a generator that yields
:class:`~armtree.api.skill.actions.Action` objects and receives each one's
result back; :class:`Process` starts an action, polls it every tick and resumes
the generator when it ends, so the procedure reads top to bottom while no tick
ever blocks. A failed action is raised into the generator as
:class:`ActionFailed` (a skill may catch it); :class:`SkillFailure` or an
uncaught failure ends the behaviour as FAILURE with its message.
"""

from __future__ import annotations

from collections.abc import Generator, Mapping
from typing import Any

import numpy as np
from py_trees.common import Status

from armtree.api.behaviour import Behaviour
from armtree.api.rig import MotionHandle, Rig
from armtree.config.params import Binding
from armtree.config.profile_access import profile_source
from armtree.config.workcell import Workcell, workcell_of
from armtree.errors import ConfigError

from .actions import Action, SkillFailure, State

Procedure = Generator[Action, Any, Any]


class ActionFailed(SkillFailure):
    """An action of the procedure failed; the message says which and why."""


class Process:
    """Drives one procedure generator; :meth:`tick` never blocks."""

    #: Actions that may end within one tick before the process yields the tick back.
    MAX_STEPS_PER_TICK = 50

    def __init__(self, procedure: Procedure) -> None:
        self.procedure = procedure
        self.action: Action | None = None
        self.result: Any = None
        self.message = ""
        self._started = False
        self._finished = False

    def tick(self) -> Status:
        """Advance the procedure; SUCCESS with :attr:`result`, FAILURE with :attr:`message`."""
        if self._finished:
            return Status.FAILURE if self.message else Status.SUCCESS
        try:
            if not self._started:
                self._started = True
                self._begin(next(self.procedure))
            for _ in range(self.MAX_STEPS_PER_TICK):
                assert self.action is not None
                state = self.action.poll()
                if state is State.RUNNING:
                    return Status.RUNNING
                if state is State.DONE:
                    self._begin(self.procedure.send(self.action.result))
                else:
                    self._begin(self.procedure.throw(ActionFailed(self.action.message)))
            return Status.RUNNING
        except StopIteration as stop:
            self._finished = True
            self.action = None
            self.result = stop.value
            return Status.SUCCESS
        except SkillFailure as exc:
            self._finished = True
            self.action = None
            self.message = str(exc)
            return Status.FAILURE

    def _begin(self, action: Action) -> None:
        self.action = action
        action.start()

    def stop(self) -> MotionHandle | None:
        """Halt the running action and close the procedure; the motion it stopped, if any."""
        handle = None
        if self.action is not None:
            handle = getattr(self.action, "handle", None)
            self.action.stop()
            self.action = None
        self._finished = True
        self.procedure.close()
        return handle


class Skill(Behaviour):
    """An armtree behaviour whose work is the generator :meth:`procedure`.

    ``initialise`` starts the procedure, ``update`` advances it one tick, and
    ``terminate`` halts it: a halted skill (INVALID) stops the arm and leaves the
    tool as it is, so a held object is never dropped.
    """

    #: Rig parts the skill cannot run without: ``"arm"``, ``"camera"``, ``"planner"``.
    NEEDS: tuple[str, ...] = ("arm",)
    # Parameters naming a place or a tag role declare it with ``Param(kind="place")`` /
    # ``kind="tag_role"``: the loader resolves them against the profile at load time
    # (with the tree's line), and setup checks them again against the rig it is given.
    #: Keys of the profile's ``workcell:`` the skill cannot run without (checked when the
    #: tree loads and again at setup); :meth:`workcell_for` when they depend on parameters.
    WORKCELL: tuple[str, ...] = ()

    def __init__(self, name: str, **params: Any) -> None:
        super().__init__(name, **params)
        self._process: Process | None = None
        self._halted: MotionHandle | None = None
        self._workcell: Workcell | None = None

    def setup(self, **kwargs: Any) -> None:
        """Take the rig; a literal place name or tag role the profile lacks, or a
        ``workcell:`` key the skill needs and the profile lacks, is a ConfigError."""
        super().setup(**kwargs)
        self._workcell = None
        for param in self.PARAMS:
            if param.kind == "place":
                self.place_name_check(param.name)
            elif param.kind == "tag_role":
                self.role_check(param.name)
        if self.has_rig:
            for key in self.workcell_needs():
                try:
                    self.workcell.need(key, self.name)
                except ConfigError as exc:
                    raise self._profile_error("workcell", exc.message) from None

    @property
    def workcell(self) -> Workcell:
        """The rig's task geometry, from its profile's ``workcell:`` section."""
        if self._workcell is None:
            self._workcell = workcell_of(getattr(self.rig, "profile", None))
        return self._workcell

    @classmethod
    def workcell_for(cls, params: Mapping[str, Any]) -> tuple[str, ...]:
        """The ``workcell:`` keys a node with these parameters needs (default
        :attr:`WORKCELL`); the loader asks before anything is built, with the tree's line."""
        return cls.WORKCELL

    def workcell_needs(self) -> tuple[str, ...]:
        """The ``workcell:`` keys this skill needs with its parameters."""
        return self.workcell_for(self.params)

    def procedure(self) -> Procedure:
        """The skill's steps; yield actions, return the result, raise SkillFailure to fail."""
        raise SkillFailure(f"{type(self).__name__} has no procedure")
        yield  # pragma: no cover - makes this a generator

    def initialise(self) -> None:
        self.feedback_message = ""
        self._process = Process(self._checked())

    def _checked(self) -> Procedure:
        for part in self.NEEDS:
            if not self.has_rig or getattr(self.rig, part, None) is None:
                raise SkillFailure(f"{self.name}: this rig has no {part}")
            if part == "camera" and self.rig.tracker is None:
                raise SkillFailure(f"{self.name}: this rig has no tracker")
        return (yield from self.procedure())

    def update(self) -> Status:
        assert self._process is not None
        status = self._process.tick()
        if status is Status.FAILURE:
            self.feedback_message = self._process.message
        elif status is Status.RUNNING and self._process.action is not None:
            self.feedback_message = _describe(self._process.action)
        return status

    def terminate(self, new_status: Status) -> None:
        if self._process is not None:
            if new_status is Status.INVALID:
                action = self._process.action
                self._halted = self._process.stop()
                if self.has_rig and self.rig.arm is not None:
                    self.rig.arm.stop()
                    if "tool" in self.RESOURCES:
                        # the tool is left as it is on purpose: what it holds stays held
                        self.note(
                            "halted",
                            step=_describe(action) if action is not None else "",
                            tool=_tool_words(self.rig.tool),
                        )
            self._process = None

    def halting(self) -> bool:
        """True while the motion a halt stopped is still decelerating."""
        if self._halted is not None and self._halted.done:
            self._halted = None
        return self._halted is not None

    # -- helpers for procedures -------------------------------------------

    def param(self, name: str) -> Any:
        """A parameter's value (read now from the blackboard when bound), else its declared default."""
        if name in self.params:
            return super().param(name)
        for declared in self.PARAMS:
            if declared.name == name and not declared.required:
                return declared.default
        raise SkillFailure(f"{self.name}: parameter {name!r} was not given")

    def point(self, value: Any, what: str) -> np.ndarray:
        """A position in mm from a place name, ``[x, y, z]``, a 4x4 pose or a ``{position}`` map."""
        return resolve_point(value, self.rig, what)

    def place_name_check(self, pname: str) -> None:
        """Raise :class:`ConfigError` if literal parameter ``pname`` names no place."""
        value = self.params.get(pname)
        if isinstance(value, str) and self.has_rig and value not in self.rig.places:
            known = ", ".join(sorted(self.rig.places)) or "none"
            raise self._profile_error(
                "places", f"{self.name}: {pname}: unknown place {value!r} (places: {known})"
            )

    def role_check(self, pname: str) -> None:
        """Raise :class:`ConfigError` if literal parameter ``pname`` names no tag role."""
        value = self.params.get(pname)
        if isinstance(value, str) and value and self.has_rig and value not in self.rig.tags:
            known = ", ".join(sorted(self.rig.tags)) or "none"
            raise self._profile_error(
                "tags", f"{self.name}: {pname}: unknown tag role {value!r} (tags: {known})"
            )

    def _profile_error(self, section: str, message: str) -> ConfigError:
        """A ConfigError at the profile's ``section`` (where the name should have been)."""
        profile = getattr(self.rig, "profile", None)
        # a loaded Profile knows where each section was written; a plain mapping does not
        marks = getattr(profile, "mark", None)
        mark = marks(section) if callable(marks) and not isinstance(profile, Mapping) else None
        if mark is not None:
            return ConfigError(message, mark.file, mark.line, mark.column)
        return ConfigError(message, profile_source(profile))

    def note(self, event: str, **data: Any) -> None:
        """Write ``event`` with ``data`` to the run log (``run.jsonl``), if the run keeps one.

        Skills record here what a status cannot say: a post-condition's measured
        numbers, a check the rig could not make, what a halt left in the tool.
        """
        runtime = self.runtime
        log = getattr(runtime, "log", None)
        if log is None or not getattr(log, "enabled", True):
            return
        log.event(
            getattr(runtime, "tick_count", 0), self.clock.now(), event, node=self.name, **data
        )

    def unverified(self, why: str) -> str:
        """Say that a check could not be made (run log ``unverified`` event); the feedback text."""
        self.note("unverified", why=why)
        return f"unverified: {why}"

    def bound(self, pname: str) -> bool:
        """True when parameter ``pname`` is a ``{key}`` blackboard binding."""
        return isinstance(self.params.get(pname), Binding)


def _tool_words(tool: Any) -> str:
    """What a halt left in the rig's tool, for the run log."""
    if tool is None:
        return "no tool"
    if tool.kind == "suction":
        return (
            "suction on, holding what it holds" if tool.holding else "suction off, holding nothing"
        )
    return f"{tool.kind or 'tool'} {'closed' if tool.holding else 'open'}, left as it is"


def _describe(action: Action) -> str:
    describe = getattr(action, "describe", None)
    return describe() if callable(describe) else type(action).__name__.lower()


def resolve_point(value: Any, rig: Rig, what: str) -> np.ndarray:
    """Turn a place name, a list, a 4x4 pose or a mapping into a position (mm, base frame).

    Raises :class:`SkillFailure` naming ``what`` when the value is none of these.
    """
    if isinstance(value, str):
        places = rig.places if rig is not None else {}
        if value not in places:
            known = ", ".join(sorted(places)) or "none"
            raise SkillFailure(f"{what}: unknown place {value!r} (places: {known})")
        value = places[value]
    if isinstance(value, dict):
        value = value.get("position", value.get("xyz"))
    if value is None:
        raise SkillFailure(f"{what}: no position given")
    arr = np.asarray(value, dtype=float)
    if arr.shape == (4, 4):
        return arr[:3, 3].copy()
    arr = arr.reshape(-1)
    if arr.size < 3 or not np.all(np.isfinite(arr[:3])):
        raise SkillFailure(f"{what}: expected [x, y, z] in mm, got {value!r}")
    return arr[:3].copy()


def as_list(xyz: np.ndarray) -> list[float]:
    """A position as a plain list of floats (mm), for the blackboard and the run log."""
    return [round(float(v), 3) for v in np.asarray(xyz, dtype=float).reshape(-1)[:3]]


__all__ = ["ActionFailed", "Process", "Skill", "as_list", "resolve_point"]
