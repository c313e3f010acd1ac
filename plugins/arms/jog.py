"""``armtree jog --rig PROFILE``: jog the arm from the keyboard and record places (Showers 2016).

The RPI report drove its Dobot from the keyboard and recorded poses to replay;
here the same is a terminal UI (textual) over any rig, simulated or real, on the
wall clock. :class:`Jogger` is the logic (what a key does to the arm), testable
without a terminal; :class:`JogApp` shows the joints, the tool's Cartesian
position, the arm's limits and the camera's detections, and maps keys to the
jogger. Recording a place writes it into the profile YAML with its comments and
layout kept (:mod:`.teach`).

Keys: ``m`` joint / Cartesian mode; joint mode: ``left``/``right`` choose the
joint, ``up``/``down`` move it; Cartesian mode: ``left``/``right`` x,
``up``/``down`` y, ``pageup``/``pagedown`` z; ``[``/``]`` step size; ``t`` tool
on/off; ``h`` home; ``r`` record the pose as a named place; ``s`` stop; ``q`` quit.
"""

from __future__ import annotations

import argparse
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from armtree.api.rig import MotionHandle, Rig
from armtree.cli.options import seed_value
from armtree.errors import ConfigError, HardwareFault
from armtree.loader.profile import Profile

#: Step sizes offered, degrees (or mm for a prismatic joint) and mm.
STEPS: tuple[float, ...] = (0.5, 1.0, 5.0, 10.0, 20.0)
#: Cartesian axes by name.
AXES = {"x": 0, "y": 1, "z": 2}


@dataclass
class Jogger:
    """What each jog key does to a rig's arm; every method returns at once.

    A new move is refused while the last one is under way (the arm finishes a
    step before the next), and targets outside the joint limits or the reach
    are refused by the driver before a byte is sent; :attr:`message` says why.
    """

    rig: Rig
    mode: str = "joint"
    joint: int = 0
    step_index: int = 3
    message: str = ""
    handle: MotionHandle | None = None
    recorded: list[str] = field(default_factory=list)
    #: What the jog last asked of the tool (grip or release).
    gripping: bool = False

    @property
    def step(self) -> float:
        """The current step, degrees (joint mode) or mm."""
        return STEPS[self.step_index]

    @property
    def arm(self) -> Any:
        """The rig's arm."""
        if self.rig.arm is None:
            raise ConfigError("jog: the profile has no arm")
        return self.rig.arm

    def busy(self) -> bool:
        """True while the last move is under way."""
        return self.handle is not None and not self.handle.done

    def toggle_mode(self) -> None:
        """Switch between joint and Cartesian jogging."""
        self.mode = "cartesian" if self.mode == "joint" else "joint"
        self.message = f"{self.mode} mode"

    def select_joint(self, delta: int) -> None:
        """Choose the next (+1) or previous (-1) joint."""
        self.joint = (self.joint + delta) % self.arm.model.dof
        self.message = f"joint {self.arm.model.joints[self.joint].name}"

    def change_step(self, delta: int) -> None:
        """A larger (+1) or smaller (-1) step."""
        self.step_index = min(len(STEPS) - 1, max(0, self.step_index + delta))
        self.message = f"step {self.step:g}"

    def jog_joint(self, sign: int) -> MotionHandle | None:
        """Move the selected joint by one step in direction ``sign``."""
        q = np.array(self.arm.joints(), dtype=float)
        q[self.joint] += sign * self.step
        return self._start(
            lambda: self.arm.move_joints(q), f"joint {self.joint + 1} -> {q[self.joint]:.1f}"
        )

    def jog_axis(self, axis: str, sign: int) -> MotionHandle | None:
        """Move the tool centre by one step (mm) along base axis ``axis``."""
        xyz = np.array(self.arm.pose()[:3, 3], dtype=float)
        xyz[AXES[axis]] += sign * self.step
        return self._start(lambda: self.arm.move_to(xyz), f"{axis} -> {xyz[AXES[axis]]:.1f} mm")

    def toggle_tool(self) -> MotionHandle | None:
        """Grip (suction on, or a gripper closed) if the jog last released, else release.

        ``set_suction`` drives whichever the arm grips with; the first press grips.
        """
        on = not self.gripping
        handle = self._start(lambda: self.arm.set_suction(on), "grip" if on else "release")
        if handle is not None:
            self.gripping = on
        return handle

    def home(self) -> MotionHandle | None:
        """Go to the arm's home configuration."""
        return self._start(self.arm.home, "home")

    def stop(self) -> None:
        """Stop the arm at once."""
        self.rig.stop()
        self.message = "stopped"

    def record(self, name: str, path: str | Path) -> list[float]:
        """Write the tool's position (mm) as place ``name`` into the profile at ``path``."""
        from .teach import record_place

        xyz = [round(float(v), 1) for v in self.arm.pose()[:3, 3]]
        record_place(path, name, xyz)
        self.rig.places[name] = xyz
        self.recorded.append(name)
        self.message = f"recorded {name}: {xyz} in {path}"
        return xyz

    def poll(self) -> None:
        """Turn the end of the last move into a message (a refusal says why)."""
        handle = self.handle
        if handle is not None and handle.done and handle.error is not None:
            self.message = f"{handle.description}: {handle.error}"
            self.handle = None

    def _start(self, begin: Any, what: str) -> MotionHandle | None:
        if self.busy():
            self.message = "busy: the last move is under way"
            return None
        self.handle = begin()
        self.message = what
        return self.handle


def limits_text(rig: Rig) -> list[tuple[str, str, str]]:
    """``(name, position, limits)`` per joint, for the table; a driver that reads servo
    counts (``joint_counts()``, bus servos) shows them beside the angle."""
    arm = rig.arm
    if arm is None:
        raise ConfigError("jog: the profile has no arm")
    q = arm.joints()
    read = getattr(arm, "joint_counts", None)
    counts = read() if callable(read) else [None] * len(q)
    return [
        (
            j.name,
            f"{q[i]:8.2f} {j.unit}" + ("" if counts[i] is None else f" ({counts[i]} counts)"),
            f"{j.lower:g} .. {j.upper:g}",
        )
        for i, j in enumerate(arm.model.joints)
    ]


def build_app(rig: Rig, save_to: Path, refresh_hz: float = 20.0) -> Any:
    """The textual app jogging ``rig``; places are recorded into ``save_to``."""
    from textual.app import App, ComposeResult
    from textual.binding import Binding
    from textual.containers import Horizontal, Vertical
    from textual.widgets import DataTable, Footer, Header, Input, Static

    jogger = Jogger(rig)

    class JogApp(App):
        """Jog and teach: joints, Cartesian position, limits, detections; keys move the arm."""

        TITLE = "armtree jog"
        AUTO_FOCUS = None  # the keys are the jog's; see on_mount
        CSS = "DataTable {height: auto; margin: 0 1;} #status {margin: 0 1;} Input {display: none;}"
        BINDINGS = [
            Binding("m", "mode", "joint/cartesian"),
            Binding("left", "key('left')", "-", show=False),
            Binding("right", "key('right')", "+", show=False),
            Binding("up", "key('up')", "+", show=False),
            Binding("down", "key('down')", "-", show=False),
            Binding("pageup", "key('pageup')", "z+", show=False),
            Binding("pagedown", "key('pagedown')", "z-", show=False),
            Binding("left_square_bracket", "step(-1)", "step-"),
            Binding("right_square_bracket", "step(1)", "step+"),
            Binding("t", "tool", "tool"),
            Binding("h", "home", "home"),
            Binding("s", "stop", "stop"),
            Binding("r", "record", "record place"),
            Binding("q", "quit", "quit"),
        ]

        def __init__(self) -> None:
            super().__init__()
            self.jogger = jogger
            self.detections: list[Any] = []

        def compose(self) -> ComposeResult:
            yield Header()
            with Horizontal():
                with Vertical():
                    yield DataTable(id="joints", show_cursor=False)
                    yield DataTable(id="pose", show_cursor=False)
                yield DataTable(id="detections", show_cursor=False)
            yield Static(id="status")
            yield Input(placeholder="place name, Enter to record, Esc to cancel", id="name")
            yield Footer()

        def on_mount(self) -> None:
            # Nothing takes the keys from the jog until a place name is asked for (a
            # focused table would scroll on the arrows, a focused input eat the letters).
            for table in self.query(DataTable):
                table.can_focus = False
            self.query_one("#name", Input).can_focus = False
            self.set_focus(None)
            self.query_one("#joints", DataTable).add_columns("joint", "position", "limits")
            self.query_one("#pose", DataTable).add_columns("tool", "mm")
            self.query_one("#detections", DataTable).add_columns("marker", "role", "x px", "y px")

        def on_ready(self) -> None:
            self.set_interval(1.0 / refresh_hz, self.refresh_view)

        def refresh_view(self) -> None:
            rig.step(rig.clock.now())
            if rig.camera is not None and rig.tracker is not None:
                try:
                    frame = rig.camera.read()
                except HardwareFault as exc:
                    jogger.message = str(exc)
                    frame = None
                if frame is not None:
                    self.detections = rig.tracker.detect(frame)
            jogger.poll()
            joints = self.query_one("#joints", DataTable)
            joints.clear()
            for i, (name, pos, lim) in enumerate(limits_text(rig)):
                mark = ">" if jogger.mode == "joint" and i == jogger.joint else " "
                joints.add_row(f"{mark}{name}", pos, lim)
            pose = self.query_one("#pose", DataTable)
            pose.clear()
            xyz = jogger.arm.pose()[:3, 3]
            for axis, v in zip("xyz", xyz, strict=True):
                pose.add_row(axis, f"{v:8.1f}")
            pose.add_row("tool", "grip" if jogger.gripping else "released")
            table = self.query_one("#detections", DataTable)
            table.clear()
            for d in self.detections:
                cx, cy = np.asarray(d.corners).mean(axis=0)
                table.add_row(str(d.id), d.role, f"{cx:.0f}", f"{cy:.0f}")
            status = (
                f"mode {jogger.mode} · step {jogger.step:g} · "
                f"{'moving' if jogger.busy() else 'ready'} · {jogger.message}"
            )
            self.query_one("#status", Static).update(status)

        def action_mode(self) -> None:
            jogger.toggle_mode()

        def action_key(self, key: str) -> None:
            if jogger.mode == "joint":
                if key in ("left", "right"):
                    jogger.select_joint(-1 if key == "left" else 1)
                elif key in ("up", "down"):
                    jogger.jog_joint(1 if key == "up" else -1)
            else:
                axis, sign = {
                    "left": ("x", -1),
                    "right": ("x", 1),
                    "up": ("y", 1),
                    "down": ("y", -1),
                    "pageup": ("z", 1),
                    "pagedown": ("z", -1),
                }[key]
                jogger.jog_axis(axis, sign)

        def action_step(self, delta: int) -> None:
            jogger.change_step(delta)

        def action_tool(self) -> None:
            jogger.toggle_tool()

        def action_home(self) -> None:
            jogger.home()

        def action_stop(self) -> None:
            jogger.stop()

        def action_record(self) -> None:
            name = self.query_one("#name", Input)
            name.display = True
            name.can_focus = True
            name.value = ""
            name.focus()

        def _hide_name(self) -> None:
            name = self.query_one("#name", Input)
            name.display = False
            name.can_focus = False
            self.set_focus(None)

        def on_input_submitted(self, event: Input.Submitted) -> None:
            self._hide_name()
            if event.value.strip():
                try:
                    jogger.record(event.value.strip(), save_to)
                except ConfigError as exc:
                    jogger.message = exc.format()

        def on_key(self, event: Any) -> None:
            name = self.query_one("#name", Input)
            if event.key == "escape" and name.display:
                self._hide_name()
                jogger.message = "not recorded"

    return JogApp()


def places_file(profile: Profile, save: str | None) -> Path:
    """Where recorded places go: ``--save FILE`` (a copy of the profile if new), else the
    profile's own file; a shipped profile is never written to."""
    from armtree.config.resolve import shipped_dir

    if profile.source is None:
        raise ConfigError(
            f"{profile.name} was not read from a file: no profile to record places into"
        )
    source = Path(profile.source)
    if save:
        target = Path(save)
        if not target.exists():
            shutil.copyfile(source, target)
        return target
    shipped = shipped_dir("profile")
    if shipped is not None and source.resolve().is_relative_to(Path(shipped).resolve()):
        raise ConfigError(
            f"{profile.name} is a shipped profile: give --save FILE.yaml to record places "
            "into a copy of it",
            file=str(source),
        )
    return source


class JogCommand:
    """``armtree jog --rig PROFILE``: jog the arm in a terminal UI and record places."""

    help = "jog the arm from the keyboard (sim or hardware) and record places into the profile"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add --rig, --set, --save and --seed."""
        from armtree.cli.options import add_set_option

        parser.add_argument("--rig", metavar="PROFILE", required=True, help="hardware profile")
        add_set_option(parser, "override a profile key, e.g. arm.port=/dev/ttyUSB0")
        parser.add_argument(
            "--save", metavar="FILE", help="record places here (a copy of the profile if new)"
        )
        parser.add_argument("--seed", type=seed_value, default=0, help="seed of a simulated world")

    def run(self, args: argparse.Namespace) -> int:
        """Build the rig on the wall clock, run the UI, close the rig; exit 0 (3 on a fault)."""
        from armtree.api.clock import WallClock
        from armtree.loader.profile import load_profile
        from armtree.runtime.rig_builder import build_rig

        manager = getattr(args, "manager", None)
        if manager is None:
            from armtree.hooks.plugin_manager import get_plugin_manager

            manager = get_plugin_manager()
        profile = load_profile(args.rig, args.overrides, manager=manager)
        target = places_file(profile, args.save)
        rig = build_rig(profile, manager, WallClock(), seed=args.seed)
        try:
            app = build_app(rig, target)
            app.run()
        finally:
            rig.close()
        for name in app.jogger.recorded:
            print(f"recorded {name}: {rig.places[name]} in {target}")
        return 0


__all__ = ["AXES", "STEPS", "JogCommand", "Jogger", "build_app", "places_file"]
