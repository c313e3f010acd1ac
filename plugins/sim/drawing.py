"""What a camera sees of the simulated world: its bodies, the arm's links and the tool's marker,
as the renderer's drawables. Reads the world under its lock; changes nothing."""

from __future__ import annotations

import functools
import math

import numpy as np

from .geometry import pose, rot_z
from .renderer import Drawable
from .world import World

#: Colour of the arm's links (dark anodised aluminium), BGR.
LINK_COLOR = (70, 70, 75)


def world_drawables(world: World) -> list[Drawable]:
    """What a camera can see now: bodies (moving Duckybots with their velocity, for motion
    blur), the arm's link boxes, the tool's marker plate."""
    with world.lock:
        out = []
        velocity: dict[str, np.ndarray] = {}
        for name, bot in world.duckybots.items():
            v = bot.command[0]
            vel = np.array([v * math.cos(bot.state.theta), v * math.sin(bot.state.theta), 0.0])
            velocity[name] = vel
            for carried in world.carried_by(name):
                velocity[carried.name] = vel
        for b in world.bodies.values():
            if b.off_table:
                continue
            size = b.size.copy()
            centre = b.center_pose()
            if b.kind == "spot":
                size[2] = 0.4  # a painted patch: just above the table so it shows
                centre = b.pose @ pose(np.eye(3), [0.0, 0.0, 0.2])
            shape = b.kind if b.kind in ("bin", "spot") else b.spec.shape
            out.append(
                Drawable(
                    name=b.name,
                    shape=shape,
                    pose=centre,
                    size=size,
                    color=b.spec.color,
                    marker=b.marker,
                    marker_pose=b.top_pose() if b.marker is not None else None,
                    wall=b.spec.wall,
                    container=world.in_bin(b),
                    velocity=velocity.get(b.name),
                )
            )
        if world.arm is not None:
            for i, (name, p, s) in enumerate(
                zip(world.arm.box_names, world.arm.box_poses, world.arm.box_sizes, strict=True)
            ):
                out.append(
                    Drawable(
                        f"link {name}",
                        "link",
                        p,
                        s,
                        LINK_COLOR,
                        tool_mounted=i in world.tool_boxes,
                    )
                )
            if world.scene.tool_marker is not None:
                plate = world.arm.tool_pose @ pose(np.eye(3), world.scene.tool_marker_offset)
                plate[:3, :3] = rot_z(math.atan2(plate[1, 0], plate[0, 0]))
                side = world.scene.tool_marker.size_mm * 1.3
                out.append(
                    Drawable(
                        "tool marker",
                        "plate",
                        plate @ pose(np.eye(3), [0.0, 0.0, -1.0]),
                        np.array([side, side, 2.0]),
                        (220, 220, 220),
                        marker=world.scene.tool_marker,
                        marker_pose=plate,
                        # mounted on a link's top face: drawn after that link
                        container=_link_under(world, plate[:3, 3]),
                    )
                )
        return out


def _link_under(world: World, point: np.ndarray) -> str | None:
    """The drawable name of the arm's link box whose top face ``point`` rests on (within
    5 mm above it), if any."""
    arm = world.arm
    assert arm is not None
    # The arm rests in most frames: the same numbers (as bytes) give the same answer.
    arrays = (np.asarray(point), np.asarray(arm.box_poses), np.asarray(arm.box_sizes))
    return _link_under_boxes(
        arm.box_names,
        tuple(a.tobytes() for a in arrays),
        tuple((a.dtype.str, a.shape) for a in arrays),
    )


@functools.lru_cache(maxsize=64)
def _link_under_boxes(
    names: tuple[str, ...], data: tuple[bytes, ...], layouts: tuple[tuple[str, tuple], ...]
) -> str | None:
    """:func:`_link_under` of the point, box poses and box sizes given as their arrays' bytes
    and (dtype, shape)."""
    point, poses, sizes = (
        np.frombuffer(b, dtype=dtype).reshape(shape)
        for b, (dtype, shape) in zip(data, layouts, strict=True)
    )
    for name, p, size in zip(names, poses, sizes, strict=True):
        local = np.linalg.inv(p) @ np.append(point, 1.0)
        half = 0.5 * np.asarray(size, dtype=float)
        if np.all(np.abs(local[:2]) <= half[:2]) and 0.0 <= local[2] - half[2] <= 5.0:
            return f"link {name}"
    return None
