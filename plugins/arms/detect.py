"""``armtree detect-port``: which serial ports there are, and which arm answers on each.

Without ``--probe`` it lists the serial ports pyserial finds (``list_ports``) with
their USB vendor and product ids. With ``--probe`` it opens each port with the
driver of every shipped real-hardware profile in turn (:data:`PROBES`: their
``arm`` sections, with the port replaced) and reports the ones whose handshake
succeeds. A handshake only reads: the Dobot V1.0 listens for status frames, the
Magician reads its pose, open-dobot asks for its board, Marlin resets its line
counter, the SSC-32 prints its version, the bus servos answer pings and say their
model; nothing moves. Ports can be named on the command line (``/dev/pts/N`` of an
emulator is not a USB device and is not listed). A driver with a ``probe()`` (one
whose connect would change settings) is probed with it instead of ``connect()``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

from armtree.api.clock import WallClock
from armtree.api.rig import RigContext
from armtree.errors import ConfigError, HardwareFault
from armtree.hooks.plugin_manager import PluginManager

#: Shipped real-hardware profiles probed in this order (the first only listens).
PROBES: tuple[str, ...] = (
    "dobot_v1",
    "dobot_v1_opendobot",
    "dobot_magician",
    "vicra",
    "dh_ssc32",
    "so101",
    "koch",
)
#: USB vendor ids of the boards and adapters arms come with (the USB-IF assignments).
VENDORS = {
    0x2341: "Arduino",
    0x2A03: "Arduino (dog hunter)",
    0x1A86: "QinHeng (CH340 USB serial)",
    0x10C4: "Silicon Labs (CP210x USB serial)",
    0x0403: "FTDI (USB serial; the U2D2 of Dynamixel arms)",
    0x067B: "Prolific (PL2303 USB serial)",
}


@dataclass
class PortInfo:
    """One serial port: its device, description and USB ids (None when not USB)."""

    device: str
    description: str = ""
    vid: int | None = None
    pid: int | None = None
    serial_number: str | None = None
    manufacturer: str | None = None
    answers: list[str] = field(default_factory=list)
    tried: dict[str, str] = field(default_factory=dict)

    @property
    def usb_id(self) -> str:
        """``VID:PID`` in hex, or ``-``."""
        return "-" if self.vid is None else f"{self.vid:04x}:{self.pid or 0:04x}"

    @property
    def vendor(self) -> str:
        """The vendor's name when its id is a known one."""
        return VENDORS.get(self.vid or -1, self.manufacturer or "")


def list_serial_ports() -> list[PortInfo]:
    """Every serial port pyserial finds, USB ones first."""
    from serial.tools import list_ports

    found = [
        PortInfo(
            p.device,
            p.description if p.description != "n/a" else "",
            p.vid,
            p.pid,
            p.serial_number,
            p.manufacturer,
        )
        for p in list_ports.comports()
    ]
    return sorted(found, key=lambda p: (p.vid is None, p.device))


def probe_port(
    port: str, manager: PluginManager, timeout: float, profiles: Sequence[str] = PROBES
) -> tuple[list[str], dict[str, str]]:
    """The profiles whose arm answers on ``port``, and what each attempt said.

    Each profile's driver is built from its ``arm`` section (``port`` replaced)
    on a wall clock and connected with ``timeout`` seconds for the handshake.
    """
    from armtree.loader.profile import load_profile

    answers, tried = [], {}
    for name in profiles:
        profile = load_profile(name, manager=manager)
        config = dict(profile.component("arm") or {})
        config["port"] = port
        factory = manager.registry.get("arm", config["type"]).factory
        context = RigContext(profile=profile, clock=WallClock())
        driver = factory(config, context)
        driver.connect_timeout = timeout
        try:
            getattr(driver, "probe", driver.connect)()
        except HardwareFault as exc:
            tried[name] = exc.message
            unusable = ("no such serial port", "not a serial port", "busy", "permission")
            if any(text in exc.message for text in unusable):
                break  # no point trying other protocols
            if "wrong board" in exc.message:
                answers.append(f"{name} ({exc.message})")
            continue
        finally:
            with contextlib.suppress(Exception):
                driver.close()
        tried[name] = "answered"
        answers.append(name)
    return answers, tried


class DetectPortCommand:
    """``armtree detect-port``: list serial ports with USB ids; ``--probe`` finds the arm."""

    help = "list serial ports with their USB ids; --probe asks each which arm is there"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add PORT..., --probe, --timeout and --json."""
        parser.add_argument(
            "ports", nargs="*", metavar="PORT", help="ports to look at (default: all found)"
        )
        parser.add_argument(
            "--probe", action="store_true", help="try each arm protocol armtree speaks"
        )
        parser.add_argument(
            "--timeout",
            type=float,
            default=3.0,
            help="seconds each protocol's handshake may take (an Arduino boots for ~2 s)",
        )
        parser.add_argument("--json", action="store_true", help="print JSON instead of a table")

    def run(self, args: argparse.Namespace) -> int:
        """List (and probe); exit 0, or 3 when probing found no arm on any port."""
        if not args.timeout > 0:
            raise ConfigError(f"--timeout {args.timeout:g}: give a positive number of seconds")
        manager = getattr(args, "manager", None)
        if manager is None:
            from armtree.hooks.plugin_manager import get_plugin_manager

            manager = get_plugin_manager()
        known = {p.device: p for p in list_serial_ports()}
        ports = (
            [known.get(d, PortInfo(d)) for d in args.ports] if args.ports else list(known.values())
        )
        if args.probe:
            for info in ports:
                info.answers, info.tried = probe_port(info.device, manager, args.timeout)
        if args.json:
            print(json.dumps([asdict(p) | {"usb_id": p.usb_id} for p in ports], indent=2))
        else:
            _print_table(ports, args.probe)
        if args.probe and not any(p.answers for p in ports):
            return 3
        return 0


def _print_table(ports: list[PortInfo], probed: bool) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console()
    if not ports:
        console.print("no serial ports found (is the arm plugged in? name a port to probe it)")
        return
    table = Table("port", "USB id", "vendor", "description", *(["arm"] if probed else []))
    for p in ports:
        row = [p.device, p.usb_id, p.vendor, p.description]
        if probed:
            row.append(", ".join(p.answers) or "[red]no arm answered[/red]")
        table.add_row(*row)
    console.print(table)
    for p in ports:
        if p.vid == 0x0403 and p.device.startswith("/dev/ttyUSB"):
            # an FTDI adapter holds each read back 16 ms by default: servo buses crawl
            name = p.device.rsplit("/", 1)[-1]
            console.print(
                f"{p.device}: FTDI adapter; for a servo bus lower its latency timer: "
                f"echo 1 | sudo tee /sys/bus/usb-serial/devices/{name}/latency_timer",
                highlight=False,
            )
    if probed:
        for p in ports:
            if p.answers:
                console.print(f"{p.device}: use --rig {p.answers[0].split()[0]}.yaml "
                              f"--set arm.port={p.device}")  # fmt: skip
            else:
                for name, said in p.tried.items():
                    console.print(f"{p.device}: {name}: {said}", highlight=False)


__all__ = ["PROBES", "VENDORS", "DetectPortCommand", "PortInfo", "list_serial_ports", "probe_port"]
