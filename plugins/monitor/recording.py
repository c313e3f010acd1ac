"""``run.mcap``: the run in the open MCAP format, for Foxglove, Rerun or any MCAP reader.

Channels (JSON messages; log times are the wall-clock instant of the run's time
``t``, ``start_ns + t``, with ``start_ns`` in the ``armtree`` metadata record):

====================== ============================ =====================================
topic                  schema                       when
====================== ============================ =====================================
/armtree/tree          armtree.Tree                 at the start (and after a reload)
/armtree/status        armtree.TreeStatus           ticks where a status or feedback changed
/armtree/blackboard    armtree.Blackboard           ticks that wrote the blackboard
/armtree/events        armtree.Record               run.jsonl's start, event and result records
/armtree/ticks         armtree.TickStats            once per run second
/log                   foxglove.Log                 each event, pause and the result, as text
/camera/image          foxglove.CompressedImage     frames the skills read, up to 10 per run s
/camera/annotations    foxglove.ImageAnnotations    with each image: marker outlines and ids
/armtree/detections    armtree.Detections           with each image: markers, corners, axes
/tf                    foxglove.FrameTransforms     base -> links -> tool -> camera, 10 per s
/scene                 foxglove.SceneUpdate         objects, arm, planned path, 10 per run s
/armtree/scene         armtree.Scene                the same in mm, as the monitor page draws it
====================== ============================ =====================================

Messages are encoded and written on a thread of their own; the run's thread
only hands over plain data (a bounded queue, so a fast virtual clock waits for
the disk rather than filling memory).
"""

from __future__ import annotations

import base64
import json
import queue
import threading
import time
from pathlib import Path
from typing import Any, BinaryIO

import cv2
import numpy as np
from mcap.writer import CompressionType, Writer

from armtree.runtime.runlog import jsonable

from . import schemas
from .model import NAMES
from .observer import TickSample
from .taps import Seen

#: Images and scenes recorded per second of run time, at most.
IMAGE_HZ = 10.0
SCENE_HZ = 10.0
JPEG_QUALITY = 80
#: Chunks are written (and can be read after a crash) once they hold this much.
CHUNK_BYTES = 256 * 1024

#: (topic, schema) of every channel, in registration order.
CHANNELS: dict[str, dict[str, Any]] = {
    "/armtree/tree": schemas.TREE,
    "/armtree/status": schemas.STATUS,
    "/armtree/blackboard": schemas.BLACKBOARD,
    "/armtree/events": schemas.RECORD,
    "/armtree/ticks": schemas.TICKS,
    "/log": schemas.LOG,
    "/camera/image": schemas.COMPRESSED_IMAGE,
    "/camera/annotations": schemas.IMAGE_ANNOTATIONS,
    "/armtree/detections": schemas.DETECTIONS,
    "/tf": schemas.FRAME_TRANSFORMS,
    "/scene": schemas.SCENE_UPDATE,
    "/armtree/scene": schemas.SCENE,
}

_ERROR_EVENTS = frozenset(
    {"exception", "component_error", "hook_error", "halt_error", "stop_timeout", "forced_exit"}
)
_INFO_EVENTS = frozenset({"paused", "resumed", "step", "reload"})


def log_level(record: dict[str, Any]) -> int:
    """foxglove.Log level of a run-log record: INFO 2, WARNING 3, ERROR 4."""
    if record.get("kind") == "result":
        return 2 if record.get("status") == "SUCCESS" else 4
    if record.get("kind") == "start":
        return 2
    event = record.get("event")
    if event in _ERROR_EVENTS:
        return 4
    return 2 if event in _INFO_EVENTS else 3


def log_text(record: dict[str, Any]) -> str:
    """One line for a run-log record."""
    kind = record.get("kind")
    if kind == "result":
        text = f"result: {record.get('status')} after {record.get('ticks')} ticks"
        return text + (f": {record['message']}" if record.get("message") else "")
    if kind == "start":
        return f"start {record.get('tree')} (seed {record.get('seed')})"
    rest = {k: v for k, v in record.items() if k not in ("kind", "tick", "t", "event", "traceback")}
    details = ", ".join(f"{k}={v}" for k, v in rest.items())
    return f"{record.get('event')}" + (f": {details}" if details else "")


def stamp(ns: int) -> dict[str, int]:
    """A Foxglove time from nanoseconds."""
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _pose_m(row: list[float]) -> dict[str, Any]:
    x, y, z, qx, qy, qz, qw = row
    return {
        "position": {"x": x / 1000.0, "y": y / 1000.0, "z": z / 1000.0},
        "orientation": {"x": qx, "y": qy, "z": qz, "w": qw},
    }


def _color(rgb: list[float], a: float = 1.0) -> dict[str, float]:
    return {"r": rgb[0], "g": rgb[1], "b": rgb[2], "a": a}


def detections_json(seen: Seen, tick: int, t: float) -> dict[str, Any]:
    """The markers found in ``seen``'s frame: ids, roles, corners and projected axes (px)."""
    frame = seen.frame
    h, w = frame.image.shape[:2]
    markers = []
    for det in seen.detections or ():
        marker: dict[str, Any] = {
            "id": int(det.id),
            "role": det.role,
            "corners": np.asarray(det.corners, dtype=float).round(1).tolist(),
        }
        if det.rvec is not None and det.tvec is not None:
            half = 0.5 * float(det.size_mm or 20.0)
            axes = np.array([[0, 0, 0], [half, 0, 0], [0, half, 0], [0, 0, half]], dtype=float)
            pts, _ = cv2.projectPoints(
                axes,
                np.asarray(det.rvec, dtype=float).reshape(3, 1),
                np.asarray(det.tvec, dtype=float).reshape(3, 1),
                np.asarray(frame.camera_matrix, dtype=float),
                np.asarray(frame.distortion, dtype=float),
            )
            marker["axes"] = pts.reshape(-1, 2).round(1).tolist()
            marker["position_mm"] = np.asarray(det.tvec, dtype=float).reshape(3).round(1).tolist()
        markers.append(marker)
    return {
        "tick": tick,
        "t": t,
        "frame": int(frame.index),
        "width": int(w),
        "height": int(h),
        "looked": seen.detections is not None,
        "markers": markers,
    }


def jpeg(image: np.ndarray, quality: int = JPEG_QUALITY) -> bytes:
    """A BGR or grey image as JPEG bytes."""
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise ValueError("OpenCV could not encode the image as JPEG")
    return data.tobytes()


class McapRecorder:
    """Writes one run's ``run.mcap``; every ``add_*`` is called from the run's thread."""

    def __init__(self, path: Path, start_ns: int, run_info: dict[str, Any]) -> None:
        self.path = Path(path)
        self.start_ns = start_ns
        self._file: BinaryIO = self.path.open("wb")
        self._writer = Writer(self._file, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        self._writer.start(profile="", library="armtree")
        self._writer.add_metadata(
            "armtree", {"start_ns": str(start_ns), **{k: str(v) for k, v in run_info.items()}}
        )
        self._channels: dict[str, int] = {}
        for topic, schema in CHANNELS.items():
            sid = self._writer.register_schema(
                name=schema["title"], encoding="jsonschema", data=schemas.encoded(schema)
            )
            self._channels[topic] = self._writer.register_channel(
                topic=topic, message_encoding="json", schema_id=sid
            )
        self.counts: dict[str, int] = dict.fromkeys(CHANNELS, 0)
        self._queue: queue.Queue = queue.Queue(maxsize=512)
        self._next_image = 0.0
        self._next_scene = 0.0
        self._next_ticks = 0.0
        self._image_seq = -1
        self._tree_paths: list[str] = []
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._work, name="armtree-mcap", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------
    # From the run's thread
    # ------------------------------------------------------------------

    def ns(self, t: float) -> int:
        """Log time of run time ``t`` (s)."""
        return self.start_ns + round(t * 1e9)

    def add_tree(self, tree: dict[str, Any], t: float) -> None:
        """The tree's description (at the start, and when a reload swapped it)."""
        self._tree_paths = [n["path"] for n in tree["nodes"]]
        self._put("/armtree/tree", t, tree)

    def add_tick(self, sample: TickSample, blackboard: dict[str, Any]) -> None:
        """A tick's statuses (when changed), feedback and blackboard writes."""
        if sample.changed or sample.feedback:
            letters = sample.letters
            paths = self._tree_paths
            self._put(
                "/armtree/status",
                sample.t,
                {
                    "tick": sample.tick,
                    "t": sample.t,
                    "changed": sample.changed,
                    "letters": letters,
                    "statuses": {p: NAMES[c] for p, c in zip(paths, letters, strict=False)},
                    "running": [p for p, c in zip(paths, letters, strict=False) if c == "R"],
                    "feedback": {paths[i]: m for i, m in sample.feedback.items() if i < len(paths)},
                },
            )
        if sample.writes:
            self._put(
                "/armtree/blackboard",
                sample.t,
                {
                    "tick": sample.tick,
                    "t": sample.t,
                    "written": sample.writes,
                    "values": dict(blackboard),
                },
            )

    def add_stats(self, tick: int, t: float, stats: dict[str, float], overruns: int) -> None:
        """Tick rate and times, once per run second."""
        if t + 1e-9 < self._next_ticks:
            return
        self._next_ticks = t + 1.0
        self._put("/armtree/ticks", t, {"tick": tick, "t": t, **stats, "overruns": overruns})

    def add_record(self, record: dict[str, Any]) -> None:
        """A run-log record (start, event or result) and its line on /log."""
        if record.get("kind") not in ("start", "event", "result"):
            return
        t = float(record.get("t") or 0.0)
        data = jsonable(record)
        self._put("/armtree/events", t, data)
        self._put("/log", t, ("log", data))

    def wants_image(self, t: float, seen: Seen | None) -> bool:
        """True when ``seen`` is a new frame and an image is due at run time ``t``."""
        return seen is not None and seen.seq != self._image_seq and t + 1e-9 >= self._next_image

    def add_image(self, seen: Seen, tick: int, t: float) -> None:
        """The frame and its detections (encoded on the writer's thread)."""
        self._image_seq = seen.seq
        self._next_image = t + 1.0 / IMAGE_HZ
        self._put("/camera/image", t, ("image", seen, tick))

    def wants_scene(self, t: float) -> bool:
        """True when a scene sample is due at run time ``t``."""
        return t + 1e-9 >= self._next_scene

    def add_scene(self, scene: dict[str, Any], t: float) -> None:
        """A scene snapshot (see :mod:`.scene`)."""
        self._next_scene = t + 1.0 / SCENE_HZ
        self._put("/armtree/scene", t, ("scene", scene))

    def close(self) -> None:
        """Write what is queued, the summary and the footer; close the file."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join()
        for finish in (self._writer.finish, self._file.close):
            try:
                finish()
            except Exception as exc:  # noqa: BLE001 - a recording must never break a run
                self.error = self.error or exc

    def _put(self, topic: str, t: float, payload: Any) -> None:
        if self._thread.is_alive():
            self._queue.put((topic, t, payload))

    # ------------------------------------------------------------------
    # The writer's thread
    # ------------------------------------------------------------------

    def _work(self) -> None:
        next_flush = time.monotonic() + 1.0
        while True:
            item = self._queue.get()
            if item is None:
                return
            try:
                self._write(*item)
            except Exception as exc:  # noqa: BLE001 - a recording must never break a run
                self.error = exc
                return
            if time.monotonic() >= next_flush:
                next_flush = time.monotonic() + 1.0
                self._file.flush()

    def _emit(self, topic: str, ns: int, message: dict[str, Any]) -> None:
        data = json.dumps(message, separators=(",", ":")).encode()
        self._writer.add_message(self._channels[topic], log_time=ns, data=data, publish_time=ns)
        self.counts[topic] += 1

    def _write(self, topic: str, t: float, payload: Any) -> None:
        ns = self.ns(t)
        if isinstance(payload, tuple):
            kind = payload[0]
            if kind == "log":
                record = payload[1]
                self._emit(
                    "/log",
                    ns,
                    {
                        "timestamp": stamp(ns),
                        "level": log_level(record),
                        "message": log_text(record),
                        "name": "armtree",
                        "file": "",
                        "line": 0,
                    },
                )
            elif kind == "image":
                self._write_image(ns, t, payload[1], payload[2])
            elif kind == "scene":
                self._write_scene(ns, payload[1])
            return
        self._emit(topic, ns, payload)

    def _write_image(self, ns: int, t: float, seen: Seen, tick: int) -> None:
        self._emit(
            "/camera/image",
            ns,
            {
                "timestamp": stamp(ns),
                "frame_id": "camera",
                "data": base64.b64encode(jpeg(seen.frame.image)).decode(),
                "format": "jpeg",
            },
        )
        found = detections_json(seen, tick, t)
        self._emit("/armtree/detections", ns, found)
        green, white = _color([0.1, 0.9, 0.3]), _color([1.0, 1.0, 1.0])
        self._emit(
            "/camera/annotations",
            ns,
            {
                "circles": [],
                "points": [
                    {
                        "timestamp": stamp(ns),
                        "type": 2,
                        "points": [{"x": x, "y": y} for x, y in m["corners"]],
                        "outline_color": green,
                        "outline_colors": [],
                        "fill_color": _color([0.1, 0.9, 0.3], 0.15),
                        "thickness": 2.0,
                    }
                    for m in found["markers"]
                ],
                "texts": [
                    {
                        "timestamp": stamp(ns),
                        "position": {"x": m["corners"][0][0], "y": m["corners"][0][1] - 6},
                        "text": f"{m['id']} {m['role']}",
                        "font_size": 14.0,
                        "text_color": white,
                        "background_color": _color([0.0, 0.0, 0.0], 0.6),
                    }
                    for m in found["markers"]
                ],
            },
        )

    def _write_scene(self, ns: int, scene: dict[str, Any]) -> None:
        self._emit("/armtree/scene", ns, scene)
        ts = stamp(ns)
        transforms = []
        entities = []
        arm = scene.get("arm")
        if arm is not None:
            links = arm["links"]
            for i, row in enumerate(links):
                pose = _pose_m(row)
                child = "tool" if i == len(links) - 1 else f"link{i}"
                transforms.append(
                    {
                        "timestamp": ts,
                        "parent_frame_id": "base",
                        "child_frame_id": child,
                        "translation": pose["position"],
                        "rotation": pose["orientation"],
                    }
                )
            entities.append(
                _entity(
                    ts,
                    "arm",
                    cubes=[
                        {
                            "pose": _pose_m(row),
                            "size": _size_m(size),
                            "color": _color([0.35, 0.35, 0.38], 0.9),
                        }
                        for row, size in zip(arm["boxes"], arm["sizes"], strict=True)
                    ],
                )
            )
        camera = scene.get("camera")
        if camera is not None:
            pose = _pose_m(camera["pose"])
            transforms.append(
                {
                    "timestamp": ts,
                    "parent_frame_id": "base",
                    "child_frame_id": "camera",
                    "translation": pose["position"],
                    "rotation": pose["orientation"],
                }
            )
            if camera.get("footprint"):
                z = _table_top(scene)
                entities.append(
                    _entity(
                        ts, "camera_view", lines=[_line(camera["footprint"], z, [1, 0.85, 0], 1)]
                    )
                )
        for obj in scene["objects"]:
            entities.append(
                _entity(
                    ts,
                    obj["name"],
                    cubes=[
                        {
                            "pose": _pose_m(obj["pose"]),
                            "size": _size_m(obj["size"]),
                            "color": _color(obj["color"], 0.5 if obj["kind"] == "table" else 1.0),
                        }
                    ],
                    texts=[]
                    if obj["kind"] == "table"
                    else [
                        {
                            "pose": _pose_m(
                                [
                                    obj["pose"][0],
                                    obj["pose"][1],
                                    obj["pose"][2] + obj["size"][2] / 2 + 15,
                                    0,
                                    0,
                                    0,
                                    1,
                                ]
                            ),
                            "billboard": True,
                            "font_size": 12.0,
                            "scale_invariant": True,
                            "color": _color([1, 1, 1]),
                            "text": obj["name"],
                        }
                    ],
                    kind=obj["kind"],
                )
            )
        if scene.get("path"):
            entities.append(
                _entity(ts, "planned_path", lines=[_line(scene["path"], None, [1, 0, 1], 0)])
            )
        if len(scene.get("trail") or ()) > 1:
            entities.append(
                _entity(ts, "tool_trail", lines=[_line(scene["trail"], None, [0, 1, 1], 0)])
            )
        self._emit("/tf", ns, {"transforms": transforms})
        self._emit("/scene", ns, {"deletions": [], "entities": entities})


def _size_m(size: list[float]) -> dict[str, float]:
    return {"x": size[0] / 1000.0, "y": size[1] / 1000.0, "z": size[2] / 1000.0}


def _table_top(scene: dict[str, Any]) -> float:
    table = next((o for o in scene["objects"] if o["kind"] == "table"), None)
    return 0.0 if table is None else table["pose"][2] + table["size"][2] / 2


def _line(
    points: list[list[float]], z: float | None, rgb: list[float], kind: int
) -> dict[str, Any]:
    return {
        "type": kind,
        "pose": _pose_m([0, 0, 0, 0, 0, 0, 1]),
        "thickness": 2.0,
        "scale_invariant": True,
        "points": [
            {"x": p[0] / 1000.0, "y": p[1] / 1000.0, "z": (p[2] if z is None else z) / 1000.0}
            for p in points
        ],
        "color": _color(rgb),
    }


def _entity(ts: dict[str, int], name: str, kind: str = "", **primitives: Any) -> dict[str, Any]:
    return {
        "timestamp": ts,
        "frame_id": "base",
        "id": name,
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": False,
        "metadata": [{"key": "kind", "value": kind}] if kind else [],
        "cubes": primitives.get("cubes", []),
        "lines": primitives.get("lines", []),
        "texts": primitives.get("texts", []),
    }


__all__ = ["CHANNELS", "McapRecorder", "detections_json", "jpeg", "log_level", "log_text"]
