"""Stopping a run's tree: halting what runs, then waiting for what is still halting."""

from __future__ import annotations

from typing import Protocol

import py_trees
from py_trees.common import Status

from armtree.api.clock import Clock
from armtree.api.rig import Rig
from armtree.runtime.interrupts import Interrupts


class HaltedRun(Protocol):
    """What :class:`Halter` reads of its run: the tree, the clock and rig it steps, and
    how long it may wait (seconds)."""

    root: py_trees.behaviour.Behaviour
    clock: Clock
    rig: Rig | None
    interrupts: Interrupts
    period: float
    stop_timeout: float

    def path_of(self, behaviour: py_trees.behaviour.Behaviour) -> str:
        """The node's path from the root."""
        ...

    def where(self, behaviour: py_trees.behaviour.Behaviour) -> str:
        """``"path (file:line)"`` of a node, for a message."""
        ...


class Halter:
    """Stops the nodes of one run's tree and waits, stepping the rig, until they are safe.

    :meth:`halt` stops every RUNNING node (and the node whose tick raised or hung,
    :attr:`raiser`, which may have started something); :meth:`settle` then steps
    the clock and rig while behaviours report ``halting()``, for at most the run's
    ``stop_timeout``. It reads the run's tree, clock and rig as they are at the call,
    so it serves a replaced tree as well.
    """

    def __init__(self, run: HaltedRun) -> None:
        self._run = run
        #: The behaviour whose tick raised (or hung): halted even when not RUNNING.
        self.raiser: py_trees.behaviour.Behaviour | None = None
        #: Set when a tick was abandoned inside a component step: the rig is not stepped again.
        self.rig_stuck = False

    def halt(self) -> list[str]:
        """Stop every RUNNING node with INVALID (calling its terminate); return errors raised.

        The root is stopped first, so composites stop their children in order;
        a sweep then stops any node left RUNNING by a tick cut short by an
        exception, deepest first. Finished nodes keep their SUCCESS or FAILURE.
        """
        run = self._run
        errors: list[str] = []
        raiser = self.raiser
        raiser_running = raiser is not None and raiser.status == Status.RUNNING
        for node in [run.root, *run.root.iterate()]:
            if node.status != Status.RUNNING:
                continue
            try:
                node.stop(Status.INVALID)
            except Exception as exc:  # noqa: BLE001 - halting continues past a broken terminate
                errors.append(f"{run.where(node)}: {type(exc).__name__}: {exc}")
        if raiser is not None and not raiser_running:
            # The node that raised may have started something before it raised.
            try:
                raiser.terminate(Status.INVALID)
            except Exception as exc:  # noqa: BLE001
                errors.append(f"{run.where(raiser)}: {type(exc).__name__}: {exc}")
        return errors

    def pending(self) -> list[py_trees.behaviour.Behaviour]:
        """The nodes whose ``halting()`` says they are not yet safe (a motion stopping)."""
        pending = []
        for node in self._run.root.iterate():
            halting = getattr(node, "halting", None)
            if halting is None:
                continue
            try:
                if halting():
                    pending.append(node)
            except Exception:  # noqa: BLE001 - a broken halting() must not hold the stop
                continue
        return pending

    def settle(self) -> list[str]:
        """Step the clock and rig while behaviours report ``halting()``, up to the run's
        ``stop_timeout``; return the paths of those still not safe."""
        run = self._run
        clock = run.clock
        deadline = clock.now() + run.stop_timeout
        pending = self.pending()
        while pending and clock.now() < deadline - 1e-9:
            target = clock.now() + run.period
            if clock.virtual:
                clock.sleep_until(target)
            else:
                run.interrupts.wake.clear()
                run.interrupts.wake.wait(max(0.0, target - clock.now()))
            if run.rig is not None and not self.rig_stuck:
                try:
                    run.rig.step(clock.now())
                except Exception:  # noqa: BLE001 - keep stopping
                    break
            pending = self.pending()
        return [run.path_of(n) for n in pending]
