"""armtree replay: a recording read back tick by tick; bad directories; recordings cut short."""

import shutil
import socket
from collections import defaultdict

import cv2
import numpy as np
import pytest

from armtree.cli.commandline import main
from armtree.plugins.monitor.recorded import MAX_LOG_BYTES, Recording
from armtree.plugins.monitor.replay import ReplayFeed
from armtree.runtime.runlog import read_log

LETTER = {"INVALID": "I", "RUNNING": "R", "SUCCESS": "S", "FAILURE": "F"}


def expected_letters(log, tick):
    """Statuses after ``tick`` rebuilt from the status records, in the tree record's order."""
    tree = next(r for r in log if r["kind"] == "tree")
    current = {n["path"]: "INVALID" for n in tree["nodes"]}
    for r in log:
        if r["kind"] == "status" and r["tick"] <= tick:
            current[r["node"]] = r["to"]
    return "".join(LETTER[current[n["path"]]] for n in tree["nodes"])


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda d: d / "missing", "no such directory"),
        (lambda d: (d / "file.txt").write_text("x") and d / "file.txt", "not a directory"),
        (lambda d: d, "no run.jsonl here, so this is not a run directory armtree wrote"),
        (
            lambda d: (d / "run.jsonl").write_text('{"kind": "other"}\n') and d,
            "run.jsonl:1: does not start with armtree's start record",
        ),
        (
            lambda d: (d / "run.jsonl").write_text("not json\nat all\n\n") and d,
            "run.jsonl:1: not a JSON line",
        ),
    ],
    ids=["missing", "file", "empty", "foreign", "not-json"],
)
def test_a_directory_that_is_no_run_is_exit_2_with_what_to_give(tmp_path, capsys, make, message):
    target = make(tmp_path)
    assert main(["replay", str(target)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def _sparse_log(folder, first: bytes, size: int):
    """``folder/run.jsonl``: ``first``, then zeros up to ``size`` bytes (a sparse file)."""
    with (folder / "run.jsonl").open("wb") as fh:
        fh.write(first)
        fh.truncate(size)
    return folder


@pytest.mark.parametrize(
    ("first", "size", "message"),
    [
        # Issue 32: a 1 GB log peaked at 1.35 GB before it was refused.
        (b'{"kind": "start", "tick_hz": 20}\n', MAX_LOG_BYTES + 1, "a replay reads"),
        # Under the limit, a log that is no run's is refused at its first record.
        (b'{"kind": "other"}\n', MAX_LOG_BYTES // 2, "does not start with armtree's start"),
    ],
    ids=["too-large", "foreign-large"],
)
def test_a_huge_run_log_is_refused_without_reading_it(tmp_path, capsys, first, size, message):
    import resource

    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    assert main(["replay", str(_sparse_log(tmp_path, first, size))]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    grown_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    assert grown_kb < 100_000, grown_kb  # far less than the file: it was not read


def test_the_state_at_any_tick_is_what_run_jsonl_says(recorded_run):
    log = read_log(recorded_run / "run.jsonl")
    rec = Recording.open(recorded_run)
    assert not rec.truncated and rec.notice == ""
    assert rec.ticks == log[-1]["ticks"]
    writes = defaultdict(dict)
    for r in log:
        if r["kind"] == "blackboard":
            writes[r["tick"]][r["key"]] = r["value"]
    for tick in sorted(
        {0, 1, 2, rec.ticks // 3, rec.ticks // 2, rec.ticks - 1, rec.ticks, *writes}
    ):
        state = rec.state(tick)
        assert state["letters"] == expected_letters(log, tick), tick
        assert set(state["written"]) == set(writes.get(tick, {}))
        for key, value in writes.get(tick, {}).items():
            assert state["blackboard"][key] == value
        assert state["events"] == [r for r in log if r["kind"] == "event" and r["tick"] <= tick]
    assert rec.state(rec.ticks)["result"]["status"] == "SUCCESS"
    assert rec.state(rec.ticks - 1)["result"] is None


def test_camera_frames_and_scenes_are_found_by_run_time(recorded_run):
    rec = Recording.open(recorded_run)
    assert rec.image_at(-1.0) is None
    header, jpeg = rec.image_at(rec.time(rec.ticks))
    image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    assert image is not None and image.shape[1] == header["detections"]["width"]
    assert header["t"] <= rec.time(rec.ticks)
    marked = [
        rec.image_at(t)[0]["detections"]["markers"]
        for t in np.arange(0.0, rec.time(rec.ticks), 0.25)
        if rec.image_at(t) is not None
    ]
    assert any(m and m[0]["id"] == 0 for m in marked)  # the ducky seen during the pick
    scene = rec.state(rec.ticks // 2)["scene"]
    assert scene["arm"] is not None and any(o["name"] == "ducky" for o in scene["objects"])


def test_a_recording_cut_short_is_shown_up_to_where_it_ends(recorded_run, tmp_path):
    cut = tmp_path / "cut"
    shutil.copytree(recorded_run, cut)
    log = read_log(recorded_run / "run.jsonl")
    lines = (cut / "run.jsonl").read_bytes().split(b"\n")
    # Cut in the middle of the first line written after half the run.
    keep = next(i for i, r in enumerate(log) if r["tick"] > log[-1]["ticks"] // 2)
    (cut / "run.jsonl").write_bytes(
        b"\n".join(lines[:keep]) + b"\n" + lines[keep][: len(lines[keep]) // 2]
    )
    data = (cut / "run.mcap").read_bytes()
    (cut / "run.mcap").write_bytes(data[: len(data) // 2])
    full = Recording.open(recorded_run)
    rec = Recording.open(cut)
    assert rec.truncated and rec.result is None
    assert f"ends at tick {rec.ticks}" in rec.notice and "cut short" in rec.notice
    assert "run.mcap was cut short" in rec.notice
    assert 0 < rec.ticks < full.ticks
    assert 0 < len(rec.topics["/camera/image"]) < len(full.topics["/camera/image"])
    # What is there is what the full recording says for those ticks.
    assert rec.letters(rec.ticks) == full.letters(rec.ticks)
    timeline = ReplayFeed(rec, "127.0.0.1", 0).hello()[1]
    assert timeline["truncated"] and timeline["ticks"] == rec.ticks
    assert "ends at tick" in timeline["notice"]


def test_without_run_mcap_the_tree_statuses_feedback_and_blackboard_come_from_run_jsonl(
    recorded_run, tmp_path
):
    bare = tmp_path / "bare"
    shutil.copytree(recorded_run, bare)
    (bare / "run.mcap").unlink()
    log = read_log(bare / "run.jsonl")
    rec = Recording.open(bare)
    assert "No run.mcap here" in rec.notice and not rec.truncated
    feedback = [r for r in log if r["kind"] == "feedback"]
    last = feedback[len(feedback) // 2]
    state = rec.state(last["tick"])
    index = {n["path"]: str(n["id"]) for n in state["tree"]["nodes"]}
    assert state["feedback"][index[last["node"]]] == last["message"]
    assert state["letters"] == expected_letters(log, last["tick"])
    assert state["scene"] is None and rec.image_at(rec.time(rec.ticks)) is None


def test_a_replay_port_in_use_is_exit_2(recorded_run, capsys):
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        assert main(["replay", str(recorded_run), "--port", str(port)]) == 2
    err = capsys.readouterr().err
    assert f"--port: port {port} on 127.0.0.1 is already in use" in err and "Traceback" not in err
