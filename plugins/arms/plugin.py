"""Commands and checks shared by the arm plugins: ``armtree emulate ARM [--profile P]``,
``armtree detect-port``, ``armtree jog``, and the fit of a profile whose arm
``--set arm.type=X`` swapped (:mod:`.fit`).

``emulate`` builds the arm plugin's firmware emulator with
``factory.emulator(config, clock)`` (the convention documented in
:mod:`armtree.plugins.arms.common`) on the wall clock, prints the device path
on its first line and serves until interrupted (Ctrl-C or SIGTERM: exit 130,
as for every interrupted armtree command), so any serial tool or vendor
client can be pointed at it.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
from typing import Any

import yaml

import armtree
from armtree.api.clock import WallClock
from armtree.cli.options import add_set_option, seed_value
from armtree.config.params import check_value
from armtree.errors import ConfigError
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.profile import Profile
from armtree.runtime.interrupts import EXIT_INTERRUPTED
from armtree.runtime.run_end import RunResult
from armtree.runtime.runner import Run

from .fit import swap_misfits


class EmulateCommand:
    """``armtree emulate``: serve an arm's firmware emulator on a pseudo-terminal."""

    help = "serve an arm's firmware emulator on a pseudo-terminal until interrupted"

    def __init__(self) -> None:
        #: Set to stop serving (SIGINT / SIGTERM set it too); for embedding and tests.
        self.stop = threading.Event()
        #: The signal that stopped serving, if one did.
        self.signalled: int | None = None

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add ``ARM``, ``--profile``, ``--seed`` and ``--set KEY=VALUE``."""
        parser.add_argument("arm", metavar="ARM", help="arm type, e.g. dobot_v1 or dobot_magician")
        parser.add_argument(
            "--profile", metavar="P", help="hardware profile whose arm section configures it"
        )
        parser.add_argument("--seed", type=seed_value, default=0, help="seed of injected faults")
        add_set_option(
            parser, "arm option, e.g. --set firmware=open-dobot (YAML value; repeatable)"
        )

    def run(self, args: argparse.Namespace) -> int:
        """Serve until stopped: exit 130 on a signal, 0 when :attr:`stop` is set; 2 for bad input."""
        manager = getattr(args, "manager", None)
        if manager is None:
            from armtree.hooks.plugin_manager import get_plugin_manager

            manager = get_plugin_manager()
        registry = manager.registry
        if not registry.has("arm", args.arm):
            names = ", ".join(registry.names("arm"))
            raise ConfigError(f"emulate: unknown arm type {args.arm!r} (known: {names})")
        factory = registry.get("arm", args.arm).factory
        make = getattr(factory, "emulator", None)
        if make is None:
            raise ConfigError(f"emulate: arm type {args.arm!r} has no firmware emulator")
        config = self._config(args, manager)
        emulator = make(config, WallClock())
        # Handlers first: a client may signal as soon as it has read the path.
        restore = self._on_signals()
        try:
            path = emulator.start()
            print(path, flush=True)
            print(f"serving {args.arm} on {path}; Ctrl-C to stop", file=sys.stderr, flush=True)
            while not self.stop.wait(0.2):
                pass
        except KeyboardInterrupt:
            self.signalled = signal.SIGINT
        finally:
            restore()
            emulator.close()
        return EXIT_INTERRUPTED if self.signalled is not None else 0

    def _config(self, args: argparse.Namespace, manager: PluginManager) -> dict[str, Any]:
        config: dict[str, Any] = {"type": args.arm}
        if args.profile:
            from armtree.loader.profile import load_profile

            profile = load_profile(args.profile, manager=manager)
            config = dict(profile.component("arm") or {})
            if config.get("type") != args.arm:
                raise profile.error(
                    "arm.type", f"the profile's arm is {config.get('type')!r}, not {args.arm!r}"
                )
        params = {p.name: p for p in manager.registry.get("arm", args.arm).params}
        for text in getattr(args, "overrides", None) or []:
            key, sep, raw = text.partition("=")
            if not sep or not key:
                raise ConfigError(f"emulate: --set {text!r}: write KEY=VALUE")
            value = yaml.safe_load(raw)
            if params and key not in params:
                raise ConfigError(f"emulate: {args.arm} has no option {key!r}")
            if key in params:
                try:
                    value = check_value(params[key], value)
                except ValueError as exc:
                    raise ConfigError(f"emulate: --set {key}: {exc}") from exc
            config[key] = value
        return config

    def _on_signal(self, signum: int, frame: Any) -> None:
        self.signalled = signum
        self.stop.set()

    def _on_signals(self) -> Any:
        if threading.current_thread() is not threading.main_thread():
            return lambda: None
        previous = {}
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, self._on_signal)

        def restore() -> None:
            for sig, handler in previous.items():
                with contextlib.suppress(ValueError, TypeError):
                    signal.signal(sig, handler)

        return restore


@armtree.hookimpl
def armtree_validate_profile(profile: Profile) -> list[ConfigError]:
    """After ``--set arm.type=X``: the profile's keys that do not fit the new arm
    (places out of its reach, a tool it does not grip with, an eye-in-hand camera
    written for another tool frame), each at its file, line and column."""
    if "arm" in getattr(profile, "invalid", frozenset()):
        return []
    return swap_misfits(profile)


def _report_pauses(run: Run) -> None:
    """Write each pause of the process the arm's driver noticed to the run log (a
    ``process_paused`` event, in the summary too), once."""
    take_pauses = getattr(getattr(getattr(run, "rig", None), "arm", None), "take_pauses", None)
    if not callable(take_pauses):
        return
    for at, gap in take_pauses():
        run.report_event(
            "process_paused",
            f"the process was suspended for {gap:.1f} s (Ctrl-Z, SIGSTOP or the machine "
            "asleep): the arm's state was read again and the pause not held against the link",
            at_s=round(float(at), 3),
            wall_s=round(float(gap), 3),
        )


@armtree.hookimpl
def armtree_tick(run: Run) -> None:
    """Report the pauses the arm's driver noticed since the last tick."""
    _report_pauses(run)


@armtree.hookimpl
def armtree_run_finished(run: Run, result: RunResult) -> None:
    """Report a pause noticed after the last tick."""
    _report_pauses(run)


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """Register ``armtree emulate``, ``armtree detect-port`` and ``armtree jog``."""
    from .detect import DetectPortCommand
    from .jog import JogCommand

    return {"emulate": EmulateCommand, "detect-port": DetectPortCommand, "jog": JogCommand}
