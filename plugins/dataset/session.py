"""What ``--dataset`` keeps for a run, and for a sweep.

A run of ``run-tree TREE --dataset DIR`` holds the dataset's writer (and so its lock)
from before anything is built to its end, records the run and appends it when it
ended by itself with a verdict ``--dataset-keep`` keeps. A run inside a sweep only
stages its episode in its own folder; the sweep's process, which holds the writer,
appends the staged episodes in seed order (:class:`SweepDataset`), so the dataset is
the same whatever the number of workers and the order runs end in.
"""

from __future__ import annotations

import contextlib
import os
import queue
import shutil
import sys
import threading
import time
from pathlib import Path
from typing import Any

from armtree.api.sweep import Sweep
from armtree.api.views import TreeView
from armtree.errors import ConfigError
from armtree.runtime.runner import Run

from . import deps, layout
from .episode import PARTIAL, is_staged, load
from .recorder import EpisodeRecorder
from .writer import DatasetWriter

KEY = "dataset"
KEEP_CHOICES = ("success", "all")
#: Verdicts ``--dataset-keep all`` keeps: every run that ended by itself.
ENDED = ("success", "failure", "false success", "false failure")
#: The folder of a sweep's run where its episode is staged.
STAGED = "dataset-episode"
#: Episodes appended together at most, in a sweep.
BATCH = 64
#: A sweep appends once this many episodes are ready in seed order, or once the oldest
#: of them has waited :data:`APPEND_AFTER_S`: each append rewrites the newest video
#: file, so appending run by run would copy it over and over.
APPEND_EVERY = 16
APPEND_AFTER_S = 20.0


def where(settings: dict[str, Any]) -> str:
    """How errors name the option: ``--dataset DIR``."""
    return f"--dataset {settings.get('dataset')}"


def check_fps(fps: int | None, tick_hz: float, at: str) -> None:
    """Refuse a dataset rate that is not a whole division of the tree's tick rate: each
    frame is taken at a tick, exactly at its timestamp only when ticks fall on frames."""
    if fps is None:
        return
    if fps <= 0:
        raise ConfigError(f"{fps} fps: give a positive number of frames a second", file=at)
    ratio = tick_hz / fps
    if ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-9:
        divisors = [d for d in range(1, int(tick_hz) + 1) if tick_hz % d == 0]
        raise ConfigError(
            f"{fps} fps does not divide the tree's {tick_hz:g} ticks a second, and a frame is "
            f"taken at a tick: give one of {', '.join(str(d) for d in divisors)}",
            file=at,
        )


def arm_facts(tree: TreeView) -> tuple[str | None, list[str] | None]:
    """The robot type (the profile's arm type) and joint names of the tree's rig, as far
    as they are known without opening a device."""
    profile = getattr(tree, "profile", None)
    arm = (profile.component("arm") if profile is not None else None) or {}
    kind = arm.get("type")
    try:
        factory = tree.registry.get("arm", str(kind)).factory
        model = factory.model(dict(arm))
        return kind, [j.name for j in model.joints]
    except Exception:  # noqa: BLE001 - checked again when the episode is appended
        return kind, None


def check_fits(info: dict[str, Any] | None, tree: TreeView, at: str) -> None:
    """Refuse, before anything moves, a rig whose arm the dataset does not record."""
    if not info or not info.get("total_episodes"):
        return
    kind, joints = arm_facts(tree)
    if kind is not None and info.get("robot_type") not in (None, kind):
        raise ConfigError(
            f"the dataset records a {info['robot_type']} arm, this rig has a {kind}: one "
            "dataset, one robot; give another folder",
            file=at,
        )
    names = (info["features"].get(layout.STATE) or {}).get("names")
    if joints is not None and names is not None and layout.vector_names(joints) != names:
        raise ConfigError(
            f"the dataset's state is {names}, this rig's would be "
            f"{layout.vector_names(joints)}; give another folder",
            file=at,
        )


def keeps(keep: str, result: Any) -> bool:
    """True when ``--dataset-keep keep`` keeps a run that ended with ``result``."""
    if result.status == "INTERRUPTED" or result.verdict not in ENDED:
        return False
    return keep == "all" or result.verdict == "success"


def tags(run: Run, result: Any) -> dict[str, Any]:
    """The ``armtree/...`` columns of the run's episode."""
    profile = getattr(run.tree, "profile", None)
    checked = any(getattr(r, "status", "not checked") != "not checked" for r in result.expectations)
    return {
        "seed": int(run.seed),
        "tree": run.tree.name,
        "rig": getattr(profile, "name", None),
        "overrides": [str(o) for o in run.settings.get("overrides") or []],
        "verdict": result.verdict,
        "checked": bool(checked),
    }


def robot_type(run: Run) -> str | None:
    """The run's arm type, from its profile."""
    profile = getattr(run.tree, "profile", None)
    arm = (profile.component("arm") if profile is not None else None) or {}
    return arm.get("type")


class RunDataset:
    """One run's recording: its writer (run-tree) or its staging folder (a sweep's run)."""

    def __init__(self, run: Run) -> None:
        settings = run.settings
        at = where(settings)
        deps.require(at)
        self.keep = settings.get("dataset_keep") or "success"
        self.sweep_dir = settings.get("sweep_run_dir")
        self.writer: DatasetWriter | None = None
        fps = settings.get("dataset_fps")
        if self.sweep_dir is None:
            check_fps(fps, run.tick_hz, f"--dataset-fps {fps}")
            self.writer = DatasetWriter(Path(settings["dataset"]), fps, at)
            try:
                check_fps(self.writer.fps, run.tick_hz, at)
                check_fits(self.writer.info, run.tree, at)
            except BaseException:
                self.writer.close()
                raise
            self.fps = self.writer.fps
            self.folder = self.writer.staging / f"run-{os.getpid()}"
        else:
            self.fps = int(fps or layout.DEFAULT_FPS)
            self.folder = Path(self.sweep_dir) / STAGED
        self.recorder: EpisodeRecorder | None = None
        self.note: str | None = None

    def start(self, run: Run) -> None:
        """Start recording on the run's rig (a rig that cannot be recorded is said so)."""
        try:
            self.recorder = EpisodeRecorder(run.rig, self.fps, self.folder)
        except (ValueError, OSError) as exc:
            self.note = f"not recorded: {exc}"
            print(f"dataset: {self.note}", file=sys.stderr, flush=True)

    def tick(self, run: Run) -> None:
        """Take the frames due by this tick. A recording that fails (the video encoder,
        a full disk) is dropped at once and said once: the run goes on unrecorded."""
        if self.recorder is None:
            return
        try:
            self.recorder.tick(run.tick_time)
        except Exception as exc:  # noqa: BLE001 - the run matters more than its recording
            recorder, self.recorder = self.recorder, None
            recorder.discard()
            why = _os_error(exc) if isinstance(exc, OSError) else f"{type(exc).__name__}: {exc}"
            self.note = f"episode dropped: recording failed at t={run.tick_time:.2f} s ({why})"
            run.report_event("dataset_failed", self.note, error=why)
            print(f"dataset: {self.note}", file=sys.stderr, flush=True)

    def finish(self, run: Run, result: Any) -> None:
        """Keep the episode or drop it; append it (run-tree) or stage it (a sweep's run)."""
        recorder, self.recorder = self.recorder, None
        if recorder is None:
            if self.note:
                result.details["dataset"] = self.note
            return
        if not keeps(self.keep, result):
            recorder.discard()
            verdict = result.verdict or result.status.lower()
            hint = (
                ""
                if self.keep == "all" or verdict == "interrupted"
                else " (--dataset-keep all keeps it)"
            )
            result.details["dataset"] = f"not kept: the run's verdict is {verdict}{hint}"
            return
        try:
            task = getattr(run.tree, "task", "") or run.tree.name
            episode = recorder.finish(task, robot_type(run), tags(run, result))
            episode.stage(self.folder)
        except (ValueError, OSError) as exc:
            recorder.discard()
            why = _os_error(exc) if isinstance(exc, OSError) else str(exc)
            self._say(result, f"episode dropped: {why}")
            return
        if self.writer is None:
            result.details["dataset"] = f"episode staged for the sweep ({episode.length} frames)"
            return
        try:
            done = self.writer.append([episode])
        except OSError as exc:
            self._say(result, f"episode dropped, the dataset unchanged: {_os_error(exc)}")
            return
        finally:
            shutil.rmtree(self.folder, ignore_errors=True)
        if done.refused:
            self._say(result, f"episode refused: {done.refused[0][1]}")
            return
        result.details["dataset"] = (
            f"episode {done.indices[0]} added to {self.writer.root} "
            f"({episode.length} frames at {self.fps} fps)"
        )

    def _say(self, result: Any, text: str) -> None:
        result.details["dataset"] = text
        print(f"dataset: {text}", file=sys.stderr, flush=True)

    def close(self) -> None:
        """Drop an unfinished recording and release the writer (every way a run ends)."""
        if self.recorder is not None:
            self.recorder.discard()
            self.recorder = None
        with contextlib.suppress(OSError):
            shutil.rmtree(self.folder.with_name(self.folder.name + PARTIAL), ignore_errors=True)
        if self.writer is not None:
            self.writer.close()


def _os_error(exc: OSError) -> str:
    if exc.errno == 28:
        return f"the disk is full ({exc.filename or exc})"
    return f"{exc.strerror or exc}" + (f": {exc.filename}" if exc.filename else "")


class SweepDataset:
    """A sweep's dataset: its writer, and a thread appending the runs' staged episodes
    in seed order once every earlier seed has ended, :data:`APPEND_EVERY` at a time (or
    what is ready after :data:`APPEND_AFTER_S`, and all the rest at the sweep's end)."""

    def __init__(self, sweep: Sweep) -> None:
        settings = sweep.settings
        at = where(settings)
        deps.require(at)
        tick_hz = float(getattr(sweep.tree, "tick_hz", 20.0) or 20.0)
        fps = settings.get("dataset_fps")
        check_fps(fps, tick_hz, f"--dataset-fps {fps}")
        self.writer = DatasetWriter(Path(settings["dataset"]), fps, at)
        try:
            check_fps(self.writer.fps, tick_hz, at)
            check_fits(self.writer.info, sweep.tree, at)
        except BaseException:
            self.writer.close()
            raise
        settings["dataset"] = str(self.writer.root)
        settings["dataset_fps"] = self.writer.fps
        settings["dataset_keep"] = settings.get("dataset_keep") or "success"
        self.order = list(sweep.seeds)
        self.ended: dict[int, dict[str, Any]] = {}
        self.next = 0
        self.added: list[int] = []
        self.dropped: list[str] = []
        self._queue: queue.Queue = queue.Queue()
        self._thread = threading.Thread(target=self._work, name="armtree-dataset")
        self._thread.start()

    def ended_run(self, outcome: dict[str, Any]) -> None:
        """A run ended (its outcome); its episode goes in once the seeds before it did."""
        self._queue.put(outcome)

    def finish(self) -> None:
        """Append what is left in seed order (after an interrupt: the runs that ended), and
        wait until it is in."""
        self._queue.put(None)
        self._thread.join()

    def close(self) -> None:
        """Release the writer, once no append is under way (Ctrl-C while waiting for the
        last appends leaves them to finish: the thread is not a daemon)."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join()
        self.writer.close()

    def summary(self) -> str:
        """One line: what the sweep added to the dataset."""
        info = self.writer.info or {}
        text = (
            f"dataset: {len(self.added)} episodes added to {self.writer.root} "
            f"(now {info.get('total_episodes', 0)} episodes, {info.get('total_frames', 0)} frames)"
        )
        if self.dropped:
            text += f"; {len(self.dropped)} dropped: {self.dropped[0]}"
        return text

    def _work(self) -> None:
        done = False
        ready: list[dict[str, Any]] = []
        waiting_since = 0.0
        while not done:
            timeout = (
                None if not ready else max(0.0, waiting_since + APPEND_AFTER_S - time.monotonic())
            )
            try:
                items = [self._queue.get(timeout=timeout)]
            except queue.Empty:
                items = []
            while True:  # everything already waiting is taken at once
                try:
                    items.append(self._queue.get_nowait())
                except queue.Empty:
                    break
            for outcome in items:
                if outcome is None:
                    done = True
                else:
                    self.ended[int(outcome["seed"])] = outcome
            while self.next < len(self.order) and (self.order[self.next] in self.ended or done):
                outcome = self.ended.pop(self.order[self.next], None)
                self.next += 1
                if outcome is not None:
                    if not ready:
                        waiting_since = time.monotonic()
                    ready.append(outcome)
            due = ready and time.monotonic() - waiting_since >= APPEND_AFTER_S
            if done or due or len(ready) >= APPEND_EVERY:
                for start in range(0, len(ready), BATCH):
                    self._append(ready[start : start + BATCH])
                ready = []

    def _append(self, outcomes: list[dict[str, Any]]) -> None:
        folders = [Path(o["run_dir"]) / STAGED for o in outcomes if o.get("run_dir")]
        for folder in folders:  # what a run killed while recording left
            shutil.rmtree(folder.with_name(STAGED + PARTIAL), ignore_errors=True)
        staged = [f for f in folders if is_staged(f)]
        if not staged:
            return
        seeds = []
        episodes = []
        for folder in staged:
            try:
                episodes.append(load(folder))
                seeds.append(folder.parent.name)
            except (OSError, ValueError) as exc:
                self.dropped.append(f"{folder}: {exc}")
        try:
            done = self.writer.append(episodes)
        except OSError as exc:
            text = f"{', '.join(seeds)}: dropped, the dataset unchanged: {_os_error(exc)}"
            self.dropped.append(text)
            print(f"dataset: {text}", file=sys.stderr, flush=True)
        else:
            self.added.extend(done.indices)
            for position, why in done.refused:
                text = f"{seeds[position]} refused: {why}"
                self.dropped.append(text)
                print(f"dataset: {text}", file=sys.stderr, flush=True)
        finally:
            for folder in staged:
                shutil.rmtree(folder, ignore_errors=True)


__all__ = ["KEEP_CHOICES", "KEY", "RunDataset", "SweepDataset", "check_fps", "keeps"]
