"""A factory-built arm driving its firmware emulator over a pty, stepped as the runtime does it.

The arm driver tests share this set-up: a :class:`~armtree.api.clock.VirtualClock`,
a :class:`~armtree.api.rig.RigContext` that records interrupts, the driver the
arm's factory builds on ``port: sim`` and the emulator it registered. Each
test module subclasses :class:`ArmSim` with its factory and its defaults.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from armtree.api.clock import VirtualClock, WallClock
from armtree.api.emulation import SHARED_KEY
from armtree.api.rig import MotionHandle, RigContext


class ArmSim:
    """A driver on ``port: sim`` and the run's stepping; a context manager that closes both.

    ``dt`` is the tick in seconds; ``limit`` how many ticks :meth:`until` waits.
    """

    dt = 0.05
    limit = 400

    def __init__(
        self, factory: Callable[[dict, RigContext], Any], config: dict, profile: Any = None
    ) -> None:
        self.clock = VirtualClock()
        self.interrupts: list[tuple[str, Exception | None]] = []
        self.context = RigContext(
            profile=profile,
            clock=self.clock,
            interrupt=lambda reason, fault=None: self.interrupts.append((reason, fault)),
        )
        self.arm = factory(config, self.context)
        self.emu = self.context.shared[SHARED_KEY]

    def tick(self, n: int = 1, dt: float | None = None) -> None:
        """Advance the clock ``n`` ticks of ``dt`` s (default :attr:`dt`), stepping each time."""
        for _ in range(n):
            now = self.clock.advance(self.dt if dt is None else dt)
            for step in self.context.steppers:
                step(now)

    def until(self, handle: MotionHandle, limit: int | None = None) -> MotionHandle:
        """Tick until ``handle`` is done (at most ``limit`` ticks, else AssertionError)."""
        for _ in range(self.limit if limit is None else limit):
            if handle.done:
                return handle
            self.tick()
        raise AssertionError(f"{handle} did not finish")

    def progress_until_done(self, handle: MotionHandle) -> list[float]:
        """Tick until ``handle`` is done; its progress after each tick."""
        progress = []
        while not handle.done:
            self.tick()
            progress.append(handle.progress)
        return progress

    def received_bytes(self) -> bytes:
        """Every byte the emulator has read from the driver, in order."""
        return b"".join(b for _, d, b in self.emu.transcript if d == "rx")

    def close(self) -> None:
        """Close the driver, then the emulator and whatever else the run registered."""
        self.arm.close()
        for closer in reversed(self.context.closers):
            closer()

    def __enter__(self) -> ArmSim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@contextmanager
def served(factory: Any, config: dict | None = None) -> Iterator[str]:
    """The device path of ``factory``'s emulator served on the wall clock, closed after.

    As ``armtree emulate`` serves it: a driver opens the path like hardware.
    """
    emulator = factory.emulator({} if config is None else config, WallClock())
    path = emulator.start()
    try:
        yield path
    finally:
        emulator.close()


def connected(sim: ArmSim) -> Iterator[ArmSim]:
    """The body of a ``sim`` fixture: connect, hand the sim to the test, close it after."""
    with sim:
        sim.arm.connect()
        yield sim
