"""``--record DIR`` writes run.mcap: read back with the mcap reader and checked against run.jsonl."""

import json
from collections import defaultdict

import cv2
import jsonschema
import numpy as np
import pytest
from mcap.reader import make_reader

from armtree.runtime.runlog import read_log

LETTER = {"INVALID": "I", "RUNNING": "R", "SUCCESS": "S", "FAILURE": "F"}


@pytest.fixture(scope="module")
def recorded(recorded_run):
    """The recorded run's log and its run.mcap read back."""
    out = recorded_run
    with (out / "run.mcap").open("rb") as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        messages = [
            (schema, channel, message, json.loads(message.data))
            for schema, channel, message in reader.iter_messages(log_time_order=False)
        ]
    return out, read_log(out / "run.jsonl"), summary, messages


def by_topic(messages):
    topics = defaultdict(list)
    for schema, channel, message, data in messages:
        topics[channel.topic].append((schema, message, data))
    return topics


def test_channels_use_foxglove_schemas_where_they_fit_and_json_everywhere(recorded):
    _, _, summary, messages = recorded
    names = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
    assert names["/camera/image"] == "foxglove.CompressedImage"
    assert names["/camera/annotations"] == "foxglove.ImageAnnotations"
    assert names["/tf"] == "foxglove.FrameTransforms"
    assert names["/scene"] == "foxglove.SceneUpdate"
    assert names["/log"] == "foxglove.Log"
    assert names["/armtree/status"] == "armtree.TreeStatus"
    assert names["/armtree/blackboard"] == "armtree.Blackboard"
    assert {c.message_encoding for c in summary.channels.values()} == {"json"}
    assert {s.encoding for s in summary.schemas.values()} == {"jsonschema"}
    # Every message satisfies its channel's schema (one of each topic, to keep it quick).
    checked = set()
    for schema, channel, _, data in messages:
        if channel.topic not in checked:
            checked.add(channel.topic)
            jsonschema.validate(data, json.loads(schema.data))
    assert checked == set(names)


def test_statuses_match_the_run_log_tick_for_tick_with_the_same_times(recorded):
    _, log, summary, messages = recorded
    start_ns = int(make_metadata(recorded)["start_ns"])
    tree = next(r for r in log if r["kind"] == "tree")
    paths = [n["path"] for n in tree["nodes"]]
    status_ticks = defaultdict(list)
    times = {}
    for r in log:
        if r["kind"] == "status":
            status_ticks[r["tick"]].append(r)
            times[r["tick"]] = r["t"]
    changed = [d for _, _, d in by_topic(messages)["/armtree/status"] if d["changed"]]
    assert [d["tick"] for d in changed] == sorted(status_ticks)
    current = dict.fromkeys(paths, "INVALID")
    msgs = {d["tick"]: d for d in changed}
    for tick in sorted(status_ticks):
        for r in status_ticks[tick]:
            assert current[r["node"]] == r["from"]
            current[r["node"]] = r["to"]
        # Halts after the last tick are logged at that tick but sampled by no tick hook.
        if tick == log[-1]["tick"]:
            continue
        assert msgs[tick]["letters"] == "".join(LETTER[current[p]] for p in paths)
        assert msgs[tick]["statuses"] == current
    for _, message, data in by_topic(messages)["/armtree/status"]:
        assert message.log_time == start_ns + round(data["t"] * 1e9)
        if data["changed"]:
            assert data["t"] == times[data["tick"]]


def make_metadata(recorded):
    out = recorded[0]
    with (out / "run.mcap").open("rb") as fh:
        reader = make_reader(fh)
        return next(m.metadata for m in reader.iter_metadata() if m.name == "armtree")


def test_blackboard_writes_and_events_are_those_of_the_run_log(recorded):
    _, log, _, messages = recorded
    topics = by_topic(messages)
    writes = defaultdict(dict)
    for r in log:
        if r["kind"] == "blackboard":
            writes[r["tick"]][r["key"]] = r["value"]
    got = {d["tick"]: d["written"] for _, _, d in topics["/armtree/blackboard"]}
    assert got == dict(writes) and got
    events = [r for r in log if r["kind"] in ("start", "event", "result")]
    assert [d for _, _, d in topics["/armtree/events"]] == events
    assert len(topics["/log"]) == len(events)
    assert topics["/log"][-1][2]["message"].startswith("result: SUCCESS")


def test_camera_images_decode_and_carry_the_markers_the_tracker_found(recorded):
    _, log, _, messages = recorded
    topics = by_topic(messages)
    images = topics["/camera/image"]
    found = topics["/armtree/detections"]
    assert len(images) == len(found) == len(topics["/camera/annotations"]) >= 5
    import base64

    data = base64.b64decode(images[0][2]["data"])
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    assert image.shape[:2] == (found[0][2]["height"], found[0][2]["width"])
    ids = {m["id"] for _, _, d in found for m in d["markers"]}
    assert 0 in ids  # the ducky's marker
    with_axes = [m for _, _, d in found for m in d["markers"] if "axes" in m]
    assert with_axes and all(len(m["axes"]) == 4 for m in with_axes)
    times = [m.log_time for _, m, _ in images]
    assert times == sorted(times) and len(set(times)) == len(times)
    # At most IMAGE_HZ per second of run time.
    assert np.min(np.diff(times)) >= 0.1e9 - 1


def test_frames_and_scene_follow_the_arm_at_ten_per_run_second(recorded):
    _, log, _, messages = recorded
    topics = by_topic(messages)
    tfs, scenes = topics["/tf"], topics["/scene"]
    run_s = log[-1]["t"]
    assert len(tfs) == len(scenes) == pytest.approx(run_s * 10, abs=2)
    children = {t["child_frame_id"] for t in tfs[0][2]["transforms"]}
    assert {"tool", "camera"} <= children
    tools = np.array(
        [
            [t["translation"][k] for k in "xyz"]
            for _, _, d in tfs
            for t in d["transforms"]
            if t["child_frame_id"] == "tool"
        ]
    )
    assert np.ptp(tools, axis=0).max() > 0.05  # the tool moved more than 5 cm (metres here)
    entities = {e["id"] for e in scenes[-1][2]["entities"]}
    assert {"arm", "table", "ducky"} <= entities
    mm = topics["/armtree/scene"][-1][2]
    ducky = next(o for o in mm["objects"] if o["name"] == "ducky")
    assert ducky["marker"] == 0 and len(ducky["pose"]) == 7
