"""run-tree --dataset and armtree sweep --dataset on the simulation: episodes a LeRobot
reader reads back, runs that behave as without --dataset, and bad input refused before
anything moves (another format or fps, a folder another writer holds, an interrupt)."""

from __future__ import annotations

import errno
import hashlib
import json
import textwrap
from pathlib import Path

import av
import numpy as np
import pyarrow.parquet as pq
import pytest
from lerobot_reader import LeRobotReader

from armtree import ConfigError, load_tree
from armtree.cli.commandline import main, run_tree_main
from armtree.plugins.dataset import deps
from armtree.plugins.dataset.check import check
from armtree.plugins.dataset.lock import DatasetLock
from armtree.plugins.dataset.recorder import EpisodeRecorder
from armtree.plugins.dataset.writer import DatasetWriter

INTERRUPTER = """
import armtree


@armtree.hookimpl
def armtree_tick(run):
    if run.tick_count == 60:
        run.interrupt("SIGINT")
"""


@pytest.fixture
def work(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "interrupter.py").write_text(INTERRUPTER)
    return tmp_path


def snapshot(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.name != ".armtree-writer.lock"
    }


def log_records(path: Path) -> list[dict]:
    out = []
    for line in path.read_text().splitlines():
        record = json.loads(line)
        for key in ("started", "wall_seconds", "tick_lateness_ms", "overruns"):
            record.pop(key, None)
        out.append(record)
    return out


@pytest.mark.slow
def test_a_run_becomes_an_episode_runs_alike_without_dataset_and_an_interrupt_drops_it(
    work, capsys
):
    assert (
        run_tree_main(
            ["load_ducky.yaml", "--quiet", "--seed", "1", "--record", "with", "--dataset", "ds"]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "dataset: episode 0 added to" in out
    assert run_tree_main(["load_ducky.yaml", "--quiet", "--seed", "1", "--record", "without"]) == 0
    assert log_records(work / "with" / "run.jsonl") == log_records(work / "without" / "run.jsonl")

    reader = LeRobotReader(work / "ds")
    (episode,) = reader.episodes
    assert episode["tasks"] == ["Load the rubber ducky onto the Duckybot"]
    assert (episode["armtree/seed"], episode["armtree/rig"], episode["armtree/tree"]) == (
        1,
        "sim_dobot",
        "load_ducky",
    )
    assert episode["armtree/verdict"] == "success" and episode["armtree/checked"] is True
    assert reader.info["robot_type"] == "dobot_v1"
    assert reader.info["features"]["observation.state"]["names"] == [
        "base.pos",
        "rear_arm.pos",
        "forearm.pos",
        "suction",
        "gripper.pos",
    ]
    # 42.7 s of run time at 10 fps: a frame at each tenth of a second, the last included
    seconds = log_records(work / "with" / "run.jsonl")[-1]["seconds"]
    assert len(reader) == int(round(seconds * 10)) + 1
    first, last = reader.item(0), reader.item(len(reader) - 1)
    assert first["observation.images.camera"].shape == (480, 640, 3)
    assert last["observation.state"][3] == 0.0  # suction off at the end: the ducky was let go

    before = snapshot(work / "ds")
    code = run_tree_main(
        [
            "load_ducky.yaml",
            "--quiet",
            "--seed",
            "2",
            "--dataset",
            "ds",
            "--plugin",
            "interrupter.py",
        ]
    )
    assert code == 130
    assert "not kept: the run's verdict is interrupted" in capsys.readouterr().out
    assert snapshot(work / "ds") == before
    assert not (work / "ds" / ".staging").exists() and not (work / "ds" / ".pending").exists()
    assert check(work / "ds").problems == []


@pytest.mark.slow
def test_a_sweep_of_three_seeds_writes_parquet_metadata_and_video_that_agree(work, capsys):
    code = main(
        [
            "sweep",
            "load_ducky.yaml",
            "--seeds",
            "1-3",
            "--workers",
            "2",
            "--out",
            "out",
            "--dataset",
            "ds",
            "--dataset-keep",
            "all",
        ]
    )
    printed = capsys.readouterr().out
    assert code in (0, 1), printed
    assert "dataset: 3 episodes added" in printed
    assert check(work / "ds").problems == []
    reader = LeRobotReader(work / "ds")
    info = reader.info
    assert [e["armtree/seed"] for e in reader.episodes] == [1, 2, 3]
    outcomes = {o["seed"]: o for o in json.loads((work / "out" / "sweep.json").read_text())["runs"]}
    assert [e["armtree/verdict"] for e in reader.episodes] == [
        outcomes[s]["verdict"] for s in (1, 2, 3)
    ]
    assert info["total_episodes"] == 3 and info["total_frames"] == len(reader)
    assert info["splits"] == {"train": "0:3"}
    data = pq.read_table(work / "ds" / "data/chunk-000/file-000.parquet")
    assert (
        data.num_rows == len(reader)
        and pq.ParquetFile(work / "ds" / "data/chunk-000/file-000.parquet").num_row_groups == 3
    )
    assert np.array_equal(data.column("index").to_numpy(), np.arange(len(reader)))
    with av.open(
        str(work / "ds" / "videos/observation.images.camera/chunk-000/file-000.mp4")
    ) as video:
        times = [float(f.time) for f in video.decode(video=0)]
    assert len(times) == len(reader)
    for e in reader.episodes:
        lo = e["videos/observation.images.camera/from_timestamp"]
        hi = e["videos/observation.images.camera/to_timestamp"]
        inside = [t for t in times if lo - 1e-4 <= t < hi - 1e-4]
        assert len(inside) == e["length"] == e["dataset_to_index"] - e["dataset_from_index"]
        rows = data.filter(data.column("episode_index").to_numpy() == e["episode_index"])
        assert rows.num_rows == e["length"]
        stamps = rows.column("timestamp").to_numpy()
        assert np.allclose(np.diff(stamps), 0.1, atol=1e-4)
        # every frame's image is where LeRobot looks for it
        item = reader.item(e["dataset_to_index"] - 1)
        assert item["observation.images.camera"].shape == (480, 640, 3)
    stats = json.loads((work / "ds" / "meta/stats.json").read_text())
    assert stats["action"]["count"] == [len(reader)]
    assert not list((work / "out" / "runs").glob("*/dataset-episode*"))


@pytest.mark.slow
@pytest.mark.parametrize(
    "rig, joints",
    [
        ("sim_dobot", ["base", "rear_arm", "forearm"]),
        ("sim_vicra", ["z", "theta1", "theta2", "wrist"]),
        ("sim_magician", None),
        ("sim_dh", None),
        ("sim_so101", ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"]),
        ("sim_koch", ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"]),
    ],
)
def test_every_sim_rig_records_episodes_check_accepts(work, capsys, rig, joints):
    args = ["load_ducky.yaml", "--rig", rig, "--quiet", "--timeout", "6", "--dataset", "ds"]
    assert run_tree_main([*args, "--dataset-keep", "all", "--seed", "3"]) == 1
    assert "dataset: episode 0 added" in capsys.readouterr().out
    report = check(work / "ds")
    assert report.problems == [] and report.episodes == 1 and report.frames == 60
    reader = LeRobotReader(work / "ds")
    names = reader.info["features"]["observation.state"]["names"]
    assert names[-2:] == ["suction", "gripper.pos"]
    if joints is not None:
        assert names[:-2] == [f"{j}.pos" for j in joints]
    assert reader.item(59)["observation.images.camera"].ndim == 3


def make_dataset(root: Path, fps: int) -> None:
    """A dataset folder holding one episode of a 3-joint dobot_v1 at ``fps``."""
    from test_dataset_writer import make_episode

    writer = DatasetWriter(root, fps, "--dataset")
    try:
        episode = make_episode(root.parent, 0, 4)
        episode.fps = fps
        writer.append([episode])
    finally:
        writer.close()


@pytest.mark.parametrize(
    "prepare, extra, message",
    [
        (
            lambda d: d.mkdir() or (d / "photo.png").write_bytes(b"x"),
            [],
            "holds files that are not a LeRobot dataset",
        ),
        (lambda d: make_dataset(d, 10), ["--dataset-fps", "5"], "at 10 fps, not 5"),
        (lambda d: make_dataset(d, 5), [], "the dataset records a"),
        (lambda d: None, ["--dataset-fps", "15"], "15 fps does not divide the tree's 20 ticks"),
    ],
)
def test_a_bad_dataset_folder_exits_2_before_anything_moves(work, capsys, prepare, extra, message):
    prepare(work / "ds")
    before = snapshot(work / "ds") if (work / "ds").exists() else {}
    code = run_tree_main(
        ["load_ducky.yaml", "--rig", "sim_vicra", "--quiet", "--dataset", "ds", *extra]
    )
    err = capsys.readouterr().err
    assert code == 2, err
    assert message in err and "--dataset" in err
    assert not (work / "runs").exists(), "nothing was built, no run log opened"
    assert (snapshot(work / "ds") if (work / "ds").exists() else {}) == before


def test_a_second_writer_of_one_folder_is_refused(work, capsys):
    (work / "ds").mkdir()
    held = DatasetLock(work / "ds", "test")
    try:
        assert run_tree_main(["load_ducky.yaml", "--quiet", "--dataset", "ds"]) == 2
        assert "ds is being written by process" in capsys.readouterr().err
        code = main(
            [
                "sweep",
                "load_ducky.yaml",
                "--seeds",
                "1-2",
                "--workers",
                "1",
                "--out",
                "out",
                "--dataset",
                "ds",
            ]
        )
        assert code == 2
        assert "wait for it to end, or give another folder" in capsys.readouterr().err
        assert not (work / "out" / "runs").exists(), "no run started"
    finally:
        held.release()


def test_only_judged_successes_are_kept_unless_all_are_asked_for(work, capsys):
    args = ["load_ducky.yaml", "--quiet", "--seed", "1", "--timeout", "2", "--dataset", "ds"]
    assert run_tree_main(args) == 1
    assert (
        "not kept: the run's verdict is failure (--dataset-keep all keeps it)"
        in capsys.readouterr().out
    )
    assert not (work / "ds" / "meta").exists()
    assert run_tree_main([*args, "--dataset-keep", "all"]) == 1
    reader = LeRobotReader(work / "ds")
    assert [e["armtree/verdict"] for e in reader.episodes] == ["failure"]
    assert len(reader) == 20  # ticks at 0 to 1.95 s: a frame at each tenth of a second


def test_a_disk_that_fills_while_recording_drops_the_episode_whole(work, capsys, monkeypatch):
    make_dataset(work / "ds", 10)
    before = snapshot(work / "ds")

    def full(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(self.work / "camera.mp4"))

    monkeypatch.setattr(EpisodeRecorder, "finish", full)
    args = ["load_ducky.yaml", "--quiet", "--seed", "1", "--timeout", "1", "--dataset", "ds"]
    assert run_tree_main([*args, "--rig", "sim_vicra", "--dataset-keep", "all"]) == 2
    assert "the dataset records a dobot_v1 arm, this rig has a vicra" in capsys.readouterr().err
    assert run_tree_main([*args, "--dataset-keep", "all"]) == 1
    captured = capsys.readouterr()
    assert "dataset: episode dropped: the disk is full (" in captured.err
    assert snapshot(work / "ds") == before
    assert not (work / "ds" / ".staging").exists()
    assert check(work / "ds").problems == []


def test_dataset_info_and_check_commands(work, capsys):
    make_dataset(work / "ds", 10)
    assert main(["dataset", "info", "ds", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert (data["episodes"], data["frames"], data["fps"], data["success_share"]) == (1, 4, 10, 1.0)
    assert data["features"]["observation.state"]["shape"] == [5]
    assert main(["dataset", "info", "ds"]) == 0
    assert "success share: 100.0 % (1 success)" in capsys.readouterr().out
    assert main(["dataset", "check", "ds"]) == 0
    assert "a valid LeRobotDataset v3.0 (1 episodes, 4 frames" in capsys.readouterr().out
    info = json.loads((work / "ds" / "meta/info.json").read_text())
    info["total_episodes"] = 2
    (work / "ds" / "meta/info.json").write_text(json.dumps(info))
    assert main(["dataset", "check", "ds"]) == 2
    assert "total_episodes 2, but meta/episodes has 1" in capsys.readouterr().out
    (work / "junk").mkdir()
    (work / "junk" / "a.txt").write_text("x")
    assert main(["dataset", "check", "junk"]) == 2
    assert "holds files that are not a LeRobot dataset" in capsys.readouterr().err


def test_without_the_extra_the_error_names_it(monkeypatch):
    real = deps.importlib.util.find_spec
    monkeypatch.setattr(
        deps.importlib.util, "find_spec", lambda name, *a: None if name == "av" else real(name, *a)
    )
    with pytest.raises(ConfigError) as missing:
        deps.require("--dataset ds")
    assert "pip install 'armtree[dataset]'" in str(missing.value)
    assert "PyAV (av)" in str(missing.value) and "pyarrow" not in str(missing.value)


def test_a_tree_names_its_task_and_a_task_that_is_not_text_is_refused(work):
    (work / "t.yaml").write_text(
        textwrap.dedent(
            """\
            tree: t
            task: Touch the tag
            root: {success: {}}
            """
        )
    )
    assert load_tree("t.yaml").task == "Touch the tag"
    (work / "bad.yaml").write_text("tree: bad\ntask: [1, 2]\nroot: {success: {}}\n")
    with pytest.raises(ConfigError) as bad:
        load_tree("bad.yaml")
    assert "task: expected a string" in str(bad.value) and bad.value.errors[0].line == 2


def test_an_encoder_that_fails_drops_the_episode_once_and_the_run_goes_on(
    work, capsys, monkeypatch
):
    make_dataset(work / "ds", 10)
    before = snapshot(work / "ds")
    calls = []

    def broken(self, now):
        calls.append(now)
        raise RuntimeError("the encoder gave up")

    monkeypatch.setattr(EpisodeRecorder, "tick", broken)
    args = ["load_ducky.yaml", "--quiet", "--seed", "1", "--record", "rec", "--dataset", "ds"]
    assert run_tree_main(args) == 0  # the task itself succeeds, unrecorded
    err = capsys.readouterr().err
    said = [line for line in err.splitlines() if line.startswith("dataset: ")]
    assert len(said) == 1 and "episode dropped: recording failed at t=" in said[0]
    assert "(RuntimeError: the encoder gave up)" in said[0]
    assert len(calls) == 1  # never asked again
    records = [json.loads(line) for line in (work / "rec" / "run.jsonl").read_text().splitlines()]
    assert [r["event"] for r in records if r.get("event") in ("dataset_failed", "hook_error")] == [
        "dataset_failed"
    ]
    assert snapshot(work / "ds") == before


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_ctrl_c_on_a_sweep_keeps_the_episodes_before_it_and_the_dataset_valid(tmp_path):
    """Issue 28: SIGINT into a real ``armtree sweep --dataset`` process once a run has
    ended (its episode waits for the next batched append): exit 130, the dataset passes
    check and a LeRobot reader, and its episodes are the first seeds in order, the ended
    runs' all in (the runs cut short are dropped whole, none half-written)."""
    import signal
    import subprocess
    import sys
    import time

    armtree = Path(sys.executable).with_name("armtree")
    proc = subprocess.Popen(
        [str(armtree), "sweep", "load_ducky.yaml", "--seeds", "1-12", "--workers", "1"]
        + ["--out", "out", "--dataset", "ds", "--dataset-keep", "all"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    # A worker writes a run's outcome.json before the sweep collects the run, so the
    # signal waits for the second run's: by then the sweep has handed the first one on.
    second = tmp_path / "out" / "runs" / "seed-2" / "outcome.json"
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and proc.poll() is None and not second.exists():
        time.sleep(0.2)
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, out + err
    assert "Traceback" not in err
    assert check(tmp_path / "ds").problems == []
    reader = LeRobotReader(tmp_path / "ds")
    seeds = [e["armtree/seed"] for e in reader.episodes]
    assert 1 <= len(seeds) < 12 and seeds == list(range(1, len(seeds) + 1)), seeds
    assert reader.info["total_episodes"] == len(seeds)
    assert reader.info["total_frames"] == len(reader)
