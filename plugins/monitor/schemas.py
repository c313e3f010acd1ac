"""JSON Schemas of the recording's channels: Foxglove's well-known names, and armtree's own.

Foxglove recognises a JSON channel by its schema *name* (``foxglove.CompressedImage``)
and reads the fields its documentation lists; the schemas below describe
exactly the fields this recording writes, so a reader can check them. Times are
``{sec, nsec}``; byte fields are base64 strings; lengths are metres (Foxglove's
unit), while armtree's own channels keep mm like run.jsonl.
"""

from __future__ import annotations

import json
from typing import Any


def _obj(title: str | None = None, required: bool = True, **props: Any) -> dict[str, Any]:
    schema: dict[str, Any] = {"type": "object", "properties": props}
    if title:
        schema["title"] = title
    if required:
        schema["required"] = sorted(props)
    return schema


def _arr(items: dict[str, Any]) -> dict[str, Any]:
    return {"type": "array", "items": items}


NUM = {"type": "number"}
INT = {"type": "integer"}
STR = {"type": "string"}
BOOL = {"type": "boolean"}
ANY: dict[str, Any] = {}
TIME = _obj("time", sec={"type": "integer", "minimum": 0}, nsec={"type": "integer", "minimum": 0})
DURATION = _obj("duration", sec=INT, nsec={"type": "integer", "minimum": 0})
VECTOR3 = _obj("foxglove.Vector3", x=NUM, y=NUM, z=NUM)
POINT2 = _obj("foxglove.Point2", x=NUM, y=NUM)
POINT3 = _obj("foxglove.Point3", x=NUM, y=NUM, z=NUM)
QUATERNION = _obj("foxglove.Quaternion", x=NUM, y=NUM, z=NUM, w=NUM)
POSE = _obj("foxglove.Pose", position=VECTOR3, orientation=QUATERNION)
COLOR = _obj("foxglove.Color", r=NUM, g=NUM, b=NUM, a=NUM)

COMPRESSED_IMAGE = _obj(
    "foxglove.CompressedImage",
    timestamp=TIME,
    frame_id=STR,
    data={"type": "string", "contentEncoding": "base64"},
    format=STR,
)
FRAME_TRANSFORM = _obj(
    "foxglove.FrameTransform",
    timestamp=TIME,
    parent_frame_id=STR,
    child_frame_id=STR,
    translation=VECTOR3,
    rotation=QUATERNION,
)
FRAME_TRANSFORMS = _obj("foxglove.FrameTransforms", transforms=_arr(FRAME_TRANSFORM))
CUBE = _obj("foxglove.CubePrimitive", pose=POSE, size=VECTOR3, color=COLOR)
LINE = _obj(
    "foxglove.LinePrimitive",
    required=False,
    type={"type": "integer", "enum": [0, 1, 2]},
    pose=POSE,
    thickness=NUM,
    scale_invariant=BOOL,
    points=_arr(POINT3),
    color=COLOR,
)
TEXT = _obj(
    "foxglove.TextPrimitive",
    pose=POSE,
    billboard=BOOL,
    font_size=NUM,
    scale_invariant=BOOL,
    color=COLOR,
    text=STR,
)
KEY_VALUE = _obj("foxglove.KeyValuePair", key=STR, value=STR)
SCENE_ENTITY = _obj(
    "foxglove.SceneEntity",
    required=False,
    timestamp=TIME,
    frame_id=STR,
    id=STR,
    lifetime=DURATION,
    frame_locked=BOOL,
    metadata=_arr(KEY_VALUE),
    cubes=_arr(CUBE),
    lines=_arr(LINE),
    texts=_arr(TEXT),
)
SCENE_UPDATE = _obj(
    "foxglove.SceneUpdate",
    deletions=_arr(
        _obj(
            "foxglove.SceneEntityDeletion",
            timestamp=TIME,
            type={"type": "integer", "enum": [0, 1]},
            id=STR,
        )
    ),
    entities=_arr(SCENE_ENTITY),
)
LOG = _obj(
    "foxglove.Log",
    timestamp=TIME,
    level={"type": "integer", "enum": [0, 1, 2, 3, 4, 5]},
    message=STR,
    name=STR,
    file=STR,
    line={"type": "integer", "minimum": 0},
)
POINTS_ANNOTATION = _obj(
    "foxglove.PointsAnnotation",
    timestamp=TIME,
    type={"type": "integer", "enum": [0, 1, 2, 3, 4]},
    points=_arr(POINT2),
    outline_color=COLOR,
    outline_colors=_arr(COLOR),
    fill_color=COLOR,
    thickness=NUM,
)
TEXT_ANNOTATION = _obj(
    "foxglove.TextAnnotation",
    timestamp=TIME,
    position=POINT2,
    text=STR,
    font_size=NUM,
    text_color=COLOR,
    background_color=COLOR,
)
IMAGE_ANNOTATIONS = _obj(
    "foxglove.ImageAnnotations",
    circles=_arr(ANY),
    points=_arr(POINTS_ANNOTATION),
    texts=_arr(TEXT_ANNOTATION),
)

TREE = _obj(
    "armtree.Tree",
    required=False,
    name=STR,
    description=STR,
    source=STR,
    tick_hz=NUM,
    nodes=_arr(
        _obj(
            "armtree.Node",
            required=False,
            id=INT,
            name=STR,
            type=STR,
            path=STR,
            file={"type": ["string", "null"]},
            line={"type": ["integer", "null"]},
            params={"type": "object"},
            children=_arr(INT),
        )
    ),
)
STATUS = _obj(
    "armtree.TreeStatus",
    tick=INT,
    t=NUM,
    letters=STR,
    statuses={"type": "object", "additionalProperties": STR},
    running=_arr(STR),
    feedback={"type": "object", "additionalProperties": STR},
)
BLACKBOARD = _obj(
    "armtree.Blackboard",
    tick=INT,
    t=NUM,
    written={"type": "object"},
    values={"type": "object"},
)
RECORD = _obj("armtree.Record", required=False, kind=STR, tick=INT, t=NUM)
TICKS = _obj(
    "armtree.TickStats",
    tick=INT,
    t=NUM,
    rate_hz=NUM,
    tick_ms_mean=NUM,
    tick_ms_max=NUM,
    overruns=INT,
)
DETECTIONS = _obj(
    "armtree.Detections",
    tick=INT,
    t=NUM,
    frame=INT,
    width=INT,
    height=INT,
    markers=_arr(
        _obj(
            "armtree.Marker",
            required=False,
            id=INT,
            role=STR,
            corners=_arr(_arr(NUM)),
            axes=_arr(_arr(NUM)),
            position_mm=_arr(NUM),
        )
    ),
)
SCENE = _obj(
    "armtree.Scene",
    required=False,
    t=NUM,
    tick=INT,
    objects=_arr({"type": "object"}),
    arm={"type": ["object", "null"]},
    camera={"type": ["object", "null"]},
    path=_arr(_arr(NUM)),
    trail=_arr(_arr(NUM)),
)


def encoded(schema: dict[str, Any]) -> bytes:
    """The schema as the bytes an MCAP schema record holds."""
    return json.dumps(schema, separators=(",", ":")).encode()


__all__ = [
    "BLACKBOARD",
    "COMPRESSED_IMAGE",
    "DETECTIONS",
    "FRAME_TRANSFORMS",
    "IMAGE_ANNOTATIONS",
    "LOG",
    "RECORD",
    "SCENE",
    "SCENE_UPDATE",
    "STATUS",
    "TICKS",
    "TREE",
    "encoded",
]
