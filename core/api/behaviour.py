"""The thin base class for armtree behaviours: declared parameters, bindings, the rig.

Lifecycle is py_trees' own (see :class:`py_trees.behaviour.Behaviour`):

* ``__init__(name, **params)``: the loader passes validated parameters; a
  ``"{key}"`` in the tree arrives as a :class:`~armtree.config.params.Binding`.
* ``setup(**kwargs)``: once, before the first tick; the runtime passes
  ``rig=``, ``clock=`` and ``runtime=``. Open nothing here that the rig owns.
* ``initialise()``: on entering RUNNING; start motions here.
* ``update()``: every tick; poll motion handles and frames, never block.
* ``terminate(new_status)``: on SUCCESS, FAILURE or INVALID (halted); stop
  what this behaviour started.
* ``halting()``: after a halt (``terminate(INVALID)``), return True while the
  hardware this behaviour commanded is still reaching a safe state (an arm
  decelerating, a pump releasing); the runtime keeps advancing the clock and
  the rig, without ticking the tree, until every behaviour returns False or
  the run's stop timeout expires. It must not block.

A behaviour that commands the arm, the tool or a pan-tilt head lists them in
:attr:`RESOURCES`; the runtime halts the previous owner before this one's
``initialise()`` so two actions never command the same hardware in one tick.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, Protocol

import py_trees
from py_trees.common import Access

from armtree.config.params import Binding, Param

from .clock import Clock
from .rig import Rig


class BehaviourRuntime(Protocol):
    """What a behaviour may ask of the run that ticks it (:class:`armtree.Run`
    satisfies it; the runtime is a layer above this one)."""

    @property
    def tick_count(self) -> int:
        """Ticks of the tree so far."""
        ...

    def claim(self, behaviour: py_trees.behaviour.Behaviour, names: Iterable[str]) -> None:
        """Give ``behaviour`` the resources ``names``, halting their running owner first."""
        ...

    def report_event(self, event: str, message: str | None = None, **data: Any) -> None:
        """Write an event to the run log at the current tick (a ``message`` is shown too)."""
        ...


class Behaviour(py_trees.behaviour.Behaviour):
    """Base for armtree leaves: parameters from the tree, blackboard bindings, rig access."""

    #: Declared parameters, checked by the loader before anything runs.
    PARAMS: tuple[Param, ...] = ()
    #: Exclusive resources commanded while RUNNING: ``"arm"``, ``"tool"``, ``"head"``.
    RESOURCES: tuple[str, ...] = ()
    #: True for a check: it answers within the tick and moves nothing (exported to
    #: BehaviorTree.CPP as a Condition rather than an Action).
    CONDITION: bool = False

    def __init__(self, name: str, **params: Any) -> None:
        super().__init__(name)
        self.params = params
        self._rig: Rig | None = None
        self._clock: Clock | None = None
        #: The run ticking this behaviour, once :meth:`setup` has been handed it.
        self.runtime: BehaviourRuntime | None = None
        self.bb = self.attach_blackboard_client(name=name)
        declared = {p.name: p for p in self.PARAMS}
        for pname, value in params.items():
            if isinstance(value, Binding):
                io = declared[pname].io if pname in declared else "in"
                access = Access.WRITE if io in ("out", "inout") else Access.READ
                self.bb.register_key(key=value.key, access=access)
                if io == "inout":
                    self.bb.register_key(key=value.key, access=Access.READ)

    def setup(self, **kwargs: Any) -> None:
        """Take the rig, clock and runtime the runtime hands every behaviour."""
        self._rig = kwargs.get("rig", self._rig)
        self._clock = kwargs.get("clock", self._clock)
        self.runtime = kwargs.get("runtime", self.runtime)

    @property
    def rig(self) -> Rig:
        """The rig the runtime handed :meth:`setup`; a RuntimeError before it has."""
        if self._rig is None:
            raise RuntimeError(
                f"{self.name}: no rig yet: the runtime hands it to setup(rig=...) before "
                "the first tick (a tree run without a profile has none)"
            )
        return self._rig

    @rig.setter
    def rig(self, rig: Rig | None) -> None:
        self._rig = rig

    @property
    def clock(self) -> Clock:
        """The run's clock :meth:`setup` was handed; a RuntimeError before it has."""
        if self._clock is None:
            raise RuntimeError(
                f"{self.name}: no clock yet: the runtime hands it to setup(clock=...) "
                "before the first tick"
            )
        return self._clock

    @clock.setter
    def clock(self, clock: Clock | None) -> None:
        self._clock = clock

    @property
    def has_rig(self) -> bool:
        """True once :meth:`setup` has been handed a rig."""
        return self._rig is not None

    def param(self, name: str) -> Any:
        """A parameter's value; a bound one is read from the blackboard now."""
        value = self.params[name]
        if isinstance(value, Binding):
            return self.bb.get(value.key)
        return value

    def output(self, name: str, value: Any) -> None:
        """Write ``value`` to the blackboard key bound to output parameter ``name``."""
        binding = self.params.get(name)
        if isinstance(binding, Binding):
            self.bb.set(binding.key, value, overwrite=True)

    def tick(self):
        """py_trees' tick, claiming :attr:`RESOURCES` before ``initialise()``."""
        if self.status != py_trees.common.Status.RUNNING and self.RESOURCES and self.runtime:
            self.runtime.claim(self, self.RESOURCES)
        yield from super().tick()

    def halting(self) -> bool:
        """True while still reaching a safe state after a halt; the default needs no time."""
        return False

    def now(self) -> float:
        """Seconds on the run's clock."""
        return self.clock.now()
