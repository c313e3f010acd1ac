"""``armtree serve-sim PROFILE``: a simulated world served as if it were a bench.

The arm's firmware emulator listens on a pseudo-terminal (as a USB serial
adapter would) and the simulated camera is rendered and streamed as MJPEG over
HTTP on 127.0.0.1 (as an IP camera would), both on the wall clock. A run then
uses the real-hardware code path against it: pyserial on a tty, OpenCV capture
of a stream, the wall clock and real-time ticks::

    armtree serve-sim sim_dobot
    run-tree load_ducky.yaml --rig dobot_v1.yaml \\
        --set arm.port=/dev/pts/N --set camera.device=http://127.0.0.1:PORT/camera.mjpg

It prints the port, the camera URL and that command line, then serves until
Ctrl-C or SIGTERM (exit 130), and prints the world's score (ground truth: the
run never sees it) before it exits; with ``--tree TREE``, also that tree's
declared outcomes (its ``expect:``) judged on the world as the run left it. The world is stepped and the camera
rendered on one thread, so a frame never shows a world half-way through a step;
the emulator serves itself on its own thread.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from armtree.api.clock import WallClock
from armtree.api.emulation import SHARED_KEY as EMULATOR_KEY
from armtree.api.rig import Rig, RigContext
from armtree.cli.options import add_set_option, seed_value
from armtree.errors import ConfigError
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.profile import Profile
from armtree.runtime.interrupts import EXIT_INTERRUPTED

from .camera import SimCamera
from .mjpeg import MjpegServer
from .rig_world import WorldStepper, attach_world
from .scoring import score_line
from .truth import world_truth

#: The shipped real-hardware profile that matches a sim profile's arm, for the hint line.
REAL_PROFILES: dict[tuple[str, str | None], str] = {
    ("dobot_v1", "original"): "dobot_v1.yaml",
    ("dobot_v1", "open-dobot"): "dobot_v1_opendobot.yaml",
    ("dobot_magician", None): "dobot_magician.yaml",
    ("vicra", None): "vicra.yaml",
    ("dh", None): "dh_ssc32.yaml",
    ("so101", None): "so101.yaml",
    ("koch", None): "koch.yaml",
}
#: How often the world is stepped, Hz (the emulator runs at its own rate).
WORLD_HZ = 100.0


@dataclass
class BenchStats:
    """What the bench did, for the closing report and for latency figures."""

    frames: int = 0
    world_steps: int = 0
    #: ``(frame index, wall time when rendering began, wall time when published)``,
    #: ``time.monotonic`` seconds (comparable between processes on one machine).
    frame_times: list[tuple[int, float, float]] = field(default_factory=list)
    render_ms: list[float] = field(default_factory=list)


class SimBench:
    """A sim profile's world, its arm emulator on a pty and its camera as an MJPEG stream.

    ``profile`` must be a loaded sim profile (``arm.port: sim``, ``camera.type:
    sim``). :meth:`start` returns once the port and the stream are up; :meth:`close`
    stops everything and returns the world's score.
    """

    def __init__(
        self,
        profile: Profile,
        manager: PluginManager,
        *,
        seed: int = 0,
        host: str = "127.0.0.1",
        camera_port: int = 0,
        quality: int = 90,
        keep_frame_times: bool = False,
        stamp_frames: bool = False,
    ) -> None:
        arm = profile.component("arm") or {}
        camera = profile.component("camera") or {}
        if arm.get("port", "sim") != "sim":
            raise profile.error("arm.port", "serve-sim serves a simulated arm: give port: sim")
        if camera.get("type") != "sim":
            raise profile.error("camera.type", "serve-sim serves a simulated camera: type: sim")
        self.profile = profile
        self.manager = manager
        self.clock = WallClock()
        self.context = RigContext(profile=profile, clock=self.clock, seed=seed)
        self.arm_config = dict(arm)
        self.camera_config = dict(camera)
        self.server = MjpegServer(host, camera_port, quality)
        self.stats = BenchStats()
        self.keep_frame_times = keep_frame_times
        self.stamp_frames = stamp_frames
        self.port_path: str | None = None
        self.camera: SimCamera | None = None
        self._stepper: WorldStepper | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._closed = False

    @property
    def camera_url(self) -> str:
        """The MJPEG stream's URL."""
        return self.server.url

    @property
    def world(self) -> Any:
        """The simulated world (ground truth; never handed to a run)."""
        return None if self._stepper is None else self._stepper._world

    def start(self) -> None:
        """Start the emulator, build the world and the camera, and start serving."""
        try:
            factory = self.manager.registry.get("arm", self.arm_config["type"]).factory
            emulator = factory.emulator(self.arm_config, self.clock, seed=self.context.seed)
            self.port_path = emulator.start()
            self.context.closers.append(emulator.close)
            self.context.shared[EMULATOR_KEY] = emulator
            self.camera = SimCamera(self.camera_config, self.context)
            attach_world(Rig(self.profile, self.clock, camera=self.camera), self.context)
            self._stepper = next(s for s in self.context.steppers if isinstance(s, WorldStepper))
            self.camera.start()
            self.server.start()
            self._thread = threading.Thread(target=self._serve, name="sim bench", daemon=True)
            self._thread.start()
        except BaseException:
            self.close()
            raise

    def _serve(self) -> None:
        assert self._stepper is not None and self.camera is not None
        period = 1.0 / WORLD_HZ
        camera, stepper, stats = self.camera, self._stepper, self.stats
        next_t = self.clock.now()
        while not self._stop.is_set():
            stepper(self.clock.now())
            stats.world_steps += 1
            began = time.monotonic()
            frame = camera.read()
            if frame is not None:
                image = stamp(frame.image, frame.index) if self.stamp_frames else frame.image
                self.server.publish(image)
                published = time.monotonic()
                stats.frames += 1
                stats.render_ms.append((published - began) * 1000.0)
                if self.keep_frame_times:
                    stats.frame_times.append((frame.index, began, published))
            next_t = max(next_t + period, self.clock.now())
            self._stop.wait(max(0.0, next_t - self.clock.now()))

    def wait(self, timeout: float | None = None) -> bool:
        """Block until :meth:`stop` is called (or ``timeout`` s); True if it was."""
        return self._stop.wait(timeout)

    def stop(self) -> None:
        """Ask the serving thread to end (safe from a signal handler)."""
        self._stop.set()

    def score(self) -> dict[str, Any]:
        """The world's score now (ground truth)."""
        world = self.world
        return {} if world is None else world.score()

    def close(self) -> dict[str, Any]:
        """Stop serving, close the stream and the emulator; returns the final score."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        score = self.score()
        if not self._closed:
            self._closed = True
            self.server.close()
            while self.context.closers:
                closer = self.context.closers.pop()
                with contextlib.suppress(Exception):
                    closer()
        return score


#: Frame-index stamp: bits of STAMP_PX x STAMP_PX pixels along the image's top left.
STAMP_BITS = 24
STAMP_PX = 6


def stamp(image: np.ndarray, index: int) -> np.ndarray:
    """A copy of ``image`` with ``index`` drawn as black/white blocks in its top-left row.

    For latency measurements only (``--stamp-frames``): the receiving side reads the
    index back with :func:`read_stamp` and matches it to the render time.
    """
    out = image.copy()
    for bit in range(STAMP_BITS):
        level = 255 if (index >> bit) & 1 else 0
        out[:STAMP_PX, bit * STAMP_PX : (bit + 1) * STAMP_PX] = level
    return out


def read_stamp(image: np.ndarray) -> int:
    """The frame index :func:`stamp` drew into ``image`` (after JPEG, by block means)."""
    index = 0
    for bit in range(STAMP_BITS):
        block = image[1 : STAMP_PX - 1, bit * STAMP_PX + 1 : (bit + 1) * STAMP_PX - 1]
        if float(np.mean(block)) > 127.0:
            index |= 1 << bit
    return index


def real_profile_for(arm: dict[str, Any]) -> str | None:
    """The shipped real-hardware profile for a sim profile's arm section, if there is one."""
    kind = arm.get("type")
    firmware = arm.get("firmware", "original") if kind == "dobot_v1" else None
    # A hand-written profile may give anything here: only names can match.
    if not isinstance(kind, str) or not (firmware is None or isinstance(firmware, str)):
        return None
    return REAL_PROFILES.get((kind, firmware))


class ServeSimCommand:
    """``armtree serve-sim``: a sim world served as a bench (arm on a pty, camera over HTTP)."""

    help = "serve a sim profile's world as a bench: arm on a pty, camera as MJPEG over http"

    def __init__(self) -> None:
        #: The bench being served, for embedding and tests.
        self.bench: SimBench | None = None

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add PROFILE, --seed, --set, --host, --camera-port, --quality and --json."""
        parser.add_argument("profile", metavar="PROFILE", help="a sim profile, e.g. sim_dobot")
        parser.add_argument(
            "--seed", type=seed_value, default=0, help="seed of the world (default 0)"
        )
        add_set_option(parser, "override a profile key, e.g. world.objects.ducky.at=[120,-140]")
        parser.add_argument(
            "--camera-port", type=int, default=0, help="HTTP port of the camera (default: any free)"
        )
        parser.add_argument(
            "--quality", type=int, default=90, help="JPEG quality of the stream, 1-100"
        )
        parser.add_argument(
            "--json", action="store_true", help="print the final score as JSON as well"
        )
        parser.add_argument(
            "--tree",
            metavar="TREE",
            help="the tree the bench is for: its declared outcomes (expect:) are judged "
            "on the world when serving ends",
        )
        parser.add_argument(
            "--frame-log",
            metavar="FILE",
            help="write each frame's index and render/publish times (JSON lines) at the end",
        )
        parser.add_argument(
            "--stamp-frames",
            action="store_true",
            help="draw each frame's index in its top-left corner (for latency measurements)",
        )

    def run(self, args: argparse.Namespace) -> int:
        """Serve until Ctrl-C or SIGTERM; print the score; exit 130 (2 for bad input)."""
        from armtree.loader.profile import load_profile

        manager = getattr(args, "manager", None)
        if manager is None:
            from armtree.hooks.plugin_manager import get_plugin_manager

            manager = get_plugin_manager()
        if not 1 <= args.quality <= 100:
            raise ConfigError(f"--quality {args.quality}: give 1 to 100")
        if not 0 <= args.camera_port <= 65535:
            raise ConfigError(f"--camera-port {args.camera_port}: give a TCP port, 0 for any")
        profile = load_profile(args.profile, args.overrides, manager=manager)
        expectations = _declared_outcomes(args.tree, profile, manager)
        try:
            bench = SimBench(
                profile,
                manager,
                seed=args.seed,
                camera_port=args.camera_port,
                quality=args.quality,
                keep_frame_times=bool(args.frame_log),
                stamp_frames=args.stamp_frames,
            )
        except OSError as exc:
            raise ConfigError(f"--camera-port {args.camera_port}: {exc.strerror or exc}") from None
        self.bench = bench
        restore = _route_signals(bench.stop)
        try:
            bench.start()
            real = real_profile_for(bench.arm_config)
            print(f"arm port: {bench.port_path}", flush=True)
            print(f"camera: {bench.camera_url}", flush=True)
            if real is not None:
                print(
                    f"run: run-tree {args.tree or 'TREE'} --rig {real} "
                    f"--set arm.port={bench.port_path} "
                    f"--set camera.device={bench.camera_url}",
                    flush=True,
                )
            print(
                f"serving {profile.name} on the wall clock; Ctrl-C to stop and score",
                file=sys.stderr,
                flush=True,
            )
            bench.wait()
        except KeyboardInterrupt:
            pass
        finally:
            score = bench.close()
            restore()
        print(f"score: {score_line(score)}", flush=True)
        if expectations is not None:
            print(_judged_outcomes(expectations, bench, profile, manager), flush=True)
        print(
            f"served {bench.stats.frames} frames, {bench.stats.world_steps} world steps",
            file=sys.stderr,
        )
        if args.json:
            print(json.dumps(score, default=str), flush=True)
        if args.frame_log:
            with open(args.frame_log, "w") as log:
                for index, began, published in bench.stats.frame_times:
                    log.write(json.dumps({"index": index, "render": began, "sent": published}))
                    log.write("\n")
        return EXIT_INTERRUPTED


def _declared_outcomes(
    tree: str | None, profile: Profile, manager: PluginManager
) -> list[Any] | None:
    """The ``expect:`` list of ``tree`` loaded against the served profile (None: no tree).

    Loaded before serving starts, so a bad tree is exit 2 with its position.
    """
    if tree is None:
        return None
    from armtree.loader.tree_loader import load_tree

    return list(load_tree(tree, rig=profile, manager=manager).expect or ())


def _judged_outcomes(
    expectations: list[Any], bench: SimBench, profile: Profile, manager: PluginManager
) -> str:
    """One ``expect:`` line per declared outcome, judged on the served world now."""
    from armtree.api.outcomes.expect import judge, predicates_for
    from armtree.runtime.display import EXPECT_MARKS

    if not expectations:
        return "expect: the tree declares no outcomes"
    world = bench.world
    truth = None if world is None else world_truth(world, profile)
    lines = []
    for r in judge(expectations, truth, predicates_for(manager.registry)):
        status = "not checked: " if r.status == "not checked" else ""
        lines.append(f"expect: {EXPECT_MARKS.get(r.status, '?')} {r.expect} ({status}{r.detail})")
    return "\n".join(lines)


def _route_signals(stop: Any) -> Any:
    """SIGINT and SIGTERM call ``stop()`` until the returned function restores the handlers."""
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    previous = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.signal(sig, lambda signum, frame: stop())

    def restore() -> None:
        for sig, handler in previous.items():
            with contextlib.suppress(ValueError, TypeError):
                signal.signal(sig, handler)

    return restore


__all__ = [
    "REAL_PROFILES",
    "BenchStats",
    "ServeSimCommand",
    "SimBench",
    "read_stamp",
    "real_profile_for",
    "stamp",
]
