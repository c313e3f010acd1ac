"""Shared infrastructure of the arm plugins: emulator base, serial driver base, helpers.

Every arm plugin (dobot_v1, dobot_magician, vicra, dh, bus_servo) is built from these
parts; the API below is stable.

Modules
-------
``pty_emulator``  :class:`PtyEmulator`, the base of every firmware emulator: the
                  pseudo-terminal, the deterministic ``step(now)`` loop, fault
                  injection (``corrupt``, ``drop``, ``cut``, ``missed_steps``) and
                  joint motion (:attr:`PtyEmulator.joints`). A subclass implements
                  ``on_bytes(data, t)`` and, for timed output, ``next_event_time()``
                  and ``on_timer(t)``; it replies with ``send(data)``.
``serial_driver`` :class:`SerialArmDriver`, the base of every driver: pyserial port
                  opening with clear :class:`~armtree.HardwareFault` (missing, busy,
                  permission), the I/O thread, link-lost detection, wrong-protocol
                  diagnosis, motion-handle bookkeeping, duplicate suppression and
                  target checks. A subclass implements ``on_data(data)``,
                  ``on_time(now)``, ``handshake_done()`` and the ArmDriver methods;
                  ``on_fault()`` makes the arm safe when the link fails (it may
                  write past the fault with ``write_anyway(data)``, bounded).
``barrier``       :class:`StepBarrier`, the in-process handshake that makes a driver
                  and its emulator deterministic on a virtual clock.
``framing``       resynchronising parsers (:class:`FixedFrameParser`,
                  :class:`LengthPrefixedParser`, :class:`CountedLengthParser`,
                  :class:`LineParser`) and
                  :func:`identify_foreign_protocol`.
``motion``        :class:`JointMove` (synchronised trapezoid, braking),
                  :class:`LineMove` (a straight tool line through IK) and
                  :class:`JointState` (reported vs true joints).
``checks``        :func:`check_joint_target`, :func:`check_position_target`.
``workspace_shapes`` the reachable workspaces of the Dobot family and of SCARA arms as
                  constraints (:func:`dobot_shape`, :func:`scara_shape`), which the
                  models return from ``workspace_shape()``.

Conventions for an arm plugin's factory (``armtree_arms`` returns ``{type: factory}``)
---------------------------------------------------------------------------------------
* ``factory(config, context) -> ArmDriver`` with ``factory.PARAMS`` (including
  ``port``; ``port: sim`` means the built-in emulator). It does not connect:
  the rig builder calls ``driver.connect()``.
* ``factory.model(config) -> KinematicModel`` builds the arm's model without
  opening a port (planners, ``armtree workspace``, benchmarks).
* ``factory.emulator(config, clock) -> PtyEmulator`` builds the arm's firmware
  emulator, not yet started; ``armtree emulate ARM`` calls it with a wall clock
  and serves it until interrupted.
* With ``port: sim`` the factory builds the emulator on ``context.clock`` and
  calls :func:`serve_in_run` (start, stepper, closer, ``context.shared``), then
  points its real driver at the pty with :func:`sim_driver_options`;
  :func:`driver_port` does both and adds the run's clock and interrupt.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from armtree.api.emulation import SHARED_KEY
from armtree.api.rig import RigContext

from .barrier import StepBarrier
from .checks import check_joint_target, check_position_target
from .framing import FixedFrameParser, LengthPrefixedParser, LineParser, identify_foreign_protocol
from .motion import JointMove, JointState, LineMove
from .pty_emulator import FAULTS, PtyEmulator
from .serial_driver import SerialArmDriver, open_serial_port


def serve_in_run(emulator: PtyEmulator, context: RigContext) -> str:
    """Start ``emulator`` for a run and return its device path.

    Its ``step`` joins ``context.steppers``, its ``close`` ``context.closers``,
    and it is published as ``context.shared[armtree.api.emulation.SHARED_KEY]``
    for the simulated world.
    """
    path = emulator.start()
    context.steppers.append(emulator.step)
    context.closers.append(emulator.close)
    context.shared[SHARED_KEY] = emulator
    return path


def sim_driver_options(emulator: PtyEmulator) -> dict[str, Any]:
    """Keyword arguments that tie a :class:`SerialArmDriver` to an in-process emulator.

    On a virtual clock: the determinism barrier and the pump that lets
    ``connect()`` boot the emulator. On a wall clock the emulator serves itself
    and the driver runs exactly as on hardware.
    """
    if emulator.clock.virtual:
        return {"barrier": emulator.barrier, "pump": emulator.step}
    return {}


def on_emulator(config: dict[str, Any]) -> bool:
    """True when the arm runs on its firmware emulator (``port: sim``, the default)."""
    return config.get("port", "sim") == "sim"


def driver_port(
    config: dict[str, Any], context: RigContext, make_emulator: Callable[[], PtyEmulator]
) -> tuple[str, dict[str, Any]]:
    """The device path a factory's driver opens, and the keyword arguments the run gives it.

    ``port: sim`` (the default) builds ``make_emulator()``, serves it in the run
    (:func:`serve_in_run`) and adds :func:`sim_driver_options`; any other port is
    the device itself. The arguments always carry the run's ``clock`` and
    ``interrupt``.
    """
    port = config.get("port", "sim")
    options: dict[str, Any] = {"clock": context.clock, "interrupt": context.interrupt}
    if on_emulator(config):
        emulator = make_emulator()
        port = serve_in_run(emulator, context)
        options.update(sim_driver_options(emulator))
    return port, options


__all__ = [
    "FAULTS",
    "FixedFrameParser",
    "JointMove",
    "JointState",
    "LengthPrefixedParser",
    "LineMove",
    "LineParser",
    "PtyEmulator",
    "SerialArmDriver",
    "StepBarrier",
    "check_joint_target",
    "check_position_target",
    "driver_port",
    "identify_foreign_protocol",
    "on_emulator",
    "open_serial_port",
    "serve_in_run",
    "sim_driver_options",
]
