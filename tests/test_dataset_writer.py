"""The LeRobot v3.0 writer on episodes made here: read back frame by frame, rolled over
at the size limits, dropped whole on a full disk, one writer per folder, other
formats refused, a sweep's episodes appended in seed order."""

from __future__ import annotations

import errno
import hashlib
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from lerobot_reader import LeRobotReader

from armtree import ConfigError
from armtree.plugins.dataset import layout, session, stats, transaction, video
from armtree.plugins.dataset.check import check
from armtree.plugins.dataset.episode import Episode
from armtree.plugins.dataset.lock import DatasetLock
from armtree.plugins.dataset.video import EpisodeVideo
from armtree.plugins.dataset.writer import DatasetWriter

FPS = 10
JOINTS = ["base", "rear_arm", "forearm"]


def colour(episode: int, frame: int) -> tuple[int, int, int]:
    """A BGR colour that says which episode and frame an image is."""
    return (40 + 50 * episode % 200, 20 + 9 * frame % 220, 200)


def make_episode(tmp: Path, number: int, length: int, task: str = "load the ducky", **kw):
    """An episode whose frame k shows colour(number, k) and whose state row k is number*1000+k."""
    path = tmp / f"episode-{number}.mp4"
    recording = EpisodeVideo(path, FPS, 64, 48)
    images = []
    for k in range(length):
        image = np.empty((48, 64, 3), np.uint8)
        image[:] = colour(number, k)
        recording.add(image)
        images.append(image[..., ::-1])
    recording.finish()
    state = np.zeros((length, 5), np.float32)
    state[:, 0] = number * 1000 + np.arange(length)
    fields = dict(
        fps=FPS,
        task=task,
        robot_type="dobot_v1",
        joints=list(JOINTS),
        state=state,
        action=state + 1,
        video=path,
        image_shape=(48, 64, 3),
        image_stats=stats.of_images(images),
        tags={
            "seed": number,
            "tree": "t",
            "rig": "sim_dobot",
            "overrides": [],
            "verdict": "success",
            "checked": True,
        },
    )
    fields.update(kw)
    return Episode(**fields)


def snapshot(root: Path) -> dict[str, str]:
    """Every file of the dataset (not the lock) and a hash of its bytes."""
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.name != ".armtree-writer.lock"
    }


@pytest.fixture
def writer(tmp_path):
    w = DatasetWriter(tmp_path / "ds", None, "--dataset ds")
    yield w
    w.close()


def test_episodes_read_back_frame_by_frame_as_lerobot_reads_them(tmp_path, writer):
    writer.append([make_episode(tmp_path, 0, 7)])
    done = writer.append([make_episode(tmp_path, 1, 5, task="sort"), make_episode(tmp_path, 2, 6)])
    assert done.indices == [1, 2] and not done.refused
    assert check(writer.root).problems == []
    reader = LeRobotReader(writer.root)
    assert len(reader) == 18 and reader.info["total_episodes"] == 3
    assert reader.tasks == {0: "load the ducky", 1: "sort"}
    for i in range(len(reader)):
        item = reader.item(i)
        number, k = divmod(int(item["observation.state"][0]), 1000)
        assert item["episode_index"] == number and item["frame_index"] == k
        assert item["task"] == ("sort" if number == 1 else "load the ducky")
        want = np.array(colour(number, k)[::-1])
        got = item["observation.images.camera"][24, 32].astype(int)
        assert np.abs(got - want).max() <= 3, (i, got, want)
    seeds = [e["armtree/seed"] for e in reader.episodes]
    assert seeds == [0, 1, 2]
    assert [e["videos/observation.images.camera/from_timestamp"] for e in reader.episodes] == [
        0.0,
        pytest.approx(0.7),
        pytest.approx(1.2),
    ]
    saved = json.loads((writer.root / layout.STATS_PATH).read_text())
    assert saved["observation.state"]["count"] == [18]
    assert np.asarray(saved["observation.images.camera"]["mean"]).shape == (3, 1, 1)


def test_files_roll_over_at_their_size_limits_and_chunks_at_chunks_size(tmp_path, writer):
    writer.append([make_episode(tmp_path, 0, 4)])
    info = json.loads((writer.root / layout.INFO_PATH).read_text())
    # a limit below one episode's size: every later episode opens new files
    info.update(chunks_size=2, data_files_size_in_mb=0.0001, video_files_size_in_mb=0.0001)
    (writer.root / layout.INFO_PATH).write_text(json.dumps(info))
    writer.append([make_episode(tmp_path, 1, 3), make_episode(tmp_path, 2, 5)])
    assert sorted(p.relative_to(writer.root).as_posix() for p in writer.root.glob("data/*/*")) == [
        "data/chunk-000/file-000.parquet",
        "data/chunk-000/file-001.parquet",
        "data/chunk-001/file-000.parquet",
    ]
    assert len(list(writer.root.glob("videos/*/*/*.mp4"))) == 3
    assert check(writer.root).problems == []
    reader = LeRobotReader(writer.root)
    assert [e["videos/observation.images.camera/from_timestamp"] for e in reader.episodes] == [
        0.0,
        0.0,
        0.0,
    ]
    item = reader.item(4 + 3 + 2)
    assert item["episode_index"] == 2 and item["frame_index"] == 2


def test_a_full_disk_drops_the_episodes_whole_and_leaves_the_dataset_as_it_was(
    tmp_path, writer, monkeypatch
):
    writer.append([make_episode(tmp_path, 0, 4)])
    before = snapshot(writer.root)

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    for target, name in ((video, "join"), (transaction.Transaction, "write_json")):
        with monkeypatch.context() as m:
            m.setattr(target, name, full)
            with pytest.raises(OSError) as caught:
                writer.append([make_episode(tmp_path, 1, 3)])
        assert caught.value.errno == errno.ENOSPC
        assert snapshot(writer.root) == before
        assert not (writer.root / transaction.PENDING).exists()
        assert check(writer.root).problems == []
    assert writer.append([make_episode(tmp_path, 1, 3)]).indices == [1]


def test_a_writer_stopped_after_its_commit_is_finished_before_it_is_not(
    tmp_path, writer, monkeypatch
):
    writer.append([make_episode(tmp_path, 0, 4)])
    before = snapshot(writer.root)
    with monkeypatch.context() as m:  # the process ends between the commit and the renames
        m.setattr(transaction, "apply", lambda root: (_ for _ in ()).throw(KeyboardInterrupt))
        with pytest.raises(KeyboardInterrupt):
            writer.append([make_episode(tmp_path, 1, 3)])
    assert (writer.root / transaction.PENDING / transaction.JOURNAL).exists()
    assert transaction.recover(writer.root) == "finished"
    assert check(writer.root).problems == [] and check(writer.root).episodes == 2
    # a writer stopped before the commit leaves files no journal names: they go
    (writer.root / transaction.PENDING).mkdir()
    (writer.root / transaction.PENDING / "0000-info.json").write_text("{}")
    assert transaction.recover(writer.root) == "discarded"
    assert snapshot(writer.root) != before and check(writer.root).problems == []


def test_one_writer_per_folder(tmp_path, writer):
    with pytest.raises(ConfigError) as refused:
        DatasetWriter(writer.root, None, "--dataset ds")
    assert "is being written by process" in str(refused.value)
    writer.close()
    DatasetWriter(writer.root, None, "--dataset ds").close()


@pytest.mark.parametrize(
    "setup, fps, message",
    [
        (lambda d: (d / "notes.txt").write_text("x"), None, "holds files that are not a LeRobot"),
        (
            lambda d: (
                (d / "meta").mkdir()
                or (d / "meta/info.json").write_text(
                    json.dumps({"codebase_version": "v2.1", "fps": 10})
                )
            ),
            None,
            "convert it with LeRobot's convert_dataset_v21_to_v30",
        ),
        (
            lambda d: (
                (d / "meta").mkdir()
                or (d / "meta/info.json").write_text(
                    json.dumps({"codebase_version": "v3.0", "fps": 30})
                )
            ),
            10,
            "at 30 fps, not 10",
        ),
        (lambda d: (d / "meta").mkdir() or (d / "meta/info.json").write_text("{"), None, "JSON"),
    ],
)
def test_a_folder_holding_another_format_or_fps_is_refused(tmp_path, setup, fps, message):
    folder = tmp_path / "other"
    folder.mkdir()
    setup(folder)
    before = snapshot(folder)
    with pytest.raises(ConfigError) as refused:
        DatasetWriter(folder, fps, "--dataset other")
    assert message in str(refused.value) and refused.value.file == "--dataset other"
    assert snapshot(folder) == before and not (folder / ".armtree-writer.lock").exists()


def test_an_episode_of_another_arm_or_rate_is_refused_and_the_rest_go_in(tmp_path, writer):
    writer.append([make_episode(tmp_path, 0, 4)])
    other = make_episode(tmp_path, 1, 4, robot_type="vicra")
    fewer = make_episode(tmp_path, 2, 4, joints=["z", "theta1"], state=np.zeros((4, 4), np.float32))
    done = writer.append([other, make_episode(tmp_path, 3, 4), fewer])
    assert done.indices == [1]
    assert [p for p, _ in done.refused] == [0, 2]
    assert "a vicra arm; the dataset records a dobot_v1" in done.refused[0][1]
    assert check(writer.root).problems == []


def test_check_names_what_is_broken(tmp_path, writer):
    writer.append([make_episode(tmp_path, 0, 4), make_episode(tmp_path, 1, 3)])
    info = json.loads((writer.root / layout.INFO_PATH).read_text())
    info["total_frames"] = 8
    (writer.root / layout.INFO_PATH).write_text(json.dumps(info))
    problems = check(writer.root).problems
    assert any("total_frames 8" in p for p in problems), problems


def test_stats_of_episodes_aggregate_to_the_stats_of_all_their_frames():
    rng = np.random.default_rng(3)
    parts = [rng.normal(i, 1 + i, size=(20 + 7 * i, 4)) for i in range(4)]
    merged = stats.aggregate([stats.of_values(p) for p in parts])
    whole = stats.of_values(np.concatenate(parts))
    for name in ("min", "max", "mean", "std"):
        np.testing.assert_allclose(merged[name], whole[name], rtol=1e-9, atol=1e-12)
    assert merged["count"].tolist() == [len(np.concatenate(parts))]


def test_a_sweep_appends_episodes_in_seed_order_whatever_order_runs_end_in(tmp_path):
    seeds = [11, 12, 13, 14, 15]
    sweep = SimpleNamespace(
        tree=SimpleNamespace(tick_hz=20.0, profile=None),
        seeds=seeds,
        settings={"dataset": str(tmp_path / "ds")},
    )
    appender = session.SweepDataset(sweep)
    try:
        assert sweep.settings["dataset_fps"] == layout.DEFAULT_FPS
        for seed in (14, 11, 15, 13, 12):
            run_dir = tmp_path / "runs" / f"seed-{seed}"
            run_dir.mkdir(parents=True)
            if seed != 13:  # seed 13's run was not kept
                make_episode(tmp_path, seed, 3).stage(run_dir / session.STAGED)
            appender.ended_run({"seed": seed, "run_dir": str(run_dir)})
        appender.finish()
        reader = LeRobotReader(tmp_path / "ds")
        assert [e["armtree/seed"] for e in reader.episodes] == [11, 12, 14, 15]
        assert not list((tmp_path / "runs").glob("*/" + session.STAGED))
        assert "4 episodes added" in appender.summary()
    finally:
        appender.close()
    assert check(tmp_path / "ds").problems == []


@pytest.mark.parametrize("fps", [3, 40, 0])
def test_a_rate_that_does_not_divide_the_tick_rate_is_refused(fps):
    with pytest.raises(ConfigError) as refused:
        session.check_fps(fps, 20.0, "--dataset-fps")
    assert "give" in str(refused.value)


def test_a_lock_says_who_holds_it(tmp_path):
    held = DatasetLock(tmp_path, "--dataset x")
    try:
        with pytest.raises(ConfigError) as refused:
            DatasetLock(tmp_path, "--dataset x")
        assert "process" in str(refused.value) and "wait for it to end" in str(refused.value)
    finally:
        held.release()


def test_image_stats_are_those_of_every_pixel_per_channel():
    rng = np.random.default_rng(5)
    images = [rng.integers(0, 256, (12, 16, 3), dtype=np.uint8) for _ in range(4)]
    got = stats.of_images(images)
    pixels = np.stack(images).reshape(-1, 3).astype(np.float64) / 255.0
    for name, want in (
        ("min", pixels.min(0)),
        ("max", pixels.max(0)),
        ("mean", pixels.mean(0)),
        ("std", pixels.std(0)),
    ):
        assert got[name].shape == (3, 1, 1)
        np.testing.assert_allclose(got[name].reshape(3), want, rtol=1e-9, atol=1e-12)
    assert got["count"].tolist() == [4]
    twice = stats.of_images(images[:2], [2, 1])
    again = stats.of_images([images[0], images[0], images[1]])
    for name in ("min", "max", "mean", "std", "count"):
        np.testing.assert_allclose(twice[name], again[name], rtol=1e-12)


@pytest.mark.parametrize(
    ("said", "value", "named"),
    [
        ("video.codec", "av1", "codec"),
        ("video.width", 1280, "width"),
        ("video.pix_fmt", "rgb24", "pix_fmt"),
    ],
)
def test_check_refuses_a_video_that_is_not_what_info_says(tmp_path, writer, said, value, named):
    writer.append([make_episode(tmp_path, 0, 4)])
    assert check(writer.root).problems == []
    info = json.loads((writer.root / layout.INFO_PATH).read_text())
    (key,) = layout.video_keys(info)
    actual = info["features"][key]["info"][said]
    info["features"][key]["info"][said] = value
    (writer.root / layout.INFO_PATH).write_text(json.dumps(info))
    problems = check(writer.root).problems
    assert any(f": {named} {actual}, but info.json says {value}" in p for p in problems), problems
