"""The simulated world as boxes for monitors and recordings (ground truth, never for skills)."""

from __future__ import annotations

import numpy as np

from armtree.api.worldview import SceneObject

from .recording import KIND_COLORS
from .world import World

#: Thickness drawn for the table top, mm.
_TABLE_MM = 10.0


def scene_objects(world: World) -> list[SceneObject]:
    """The table, every body on or above it, and each Duckybot's route, as boxes."""
    with world.lock:
        t = world.table
        table_pose = np.eye(4)
        table_pose[:3, 3] = (
            0.5 * (t.x[0] + t.x[1]),
            0.5 * (t.y[0] + t.y[1]),
            t.height - 0.5 * _TABLE_MM,
        )
        objects = [
            SceneObject(
                "table",
                "table",
                table_pose,
                (t.x[1] - t.x[0], t.y[1] - t.y[0], _TABLE_MM),
                (0.82, 0.73, 0.59),
            )
        ]
        routes = {
            name: [
                (float(p[0]), float(p[1]))
                for p in [bot.trail[0], *(leg.target for leg in bot.route)]
            ]
            for name, bot in world.duckybots.items()
        }
        for body in world.bodies.values():
            if body.off_table:
                continue
            b, g, r = KIND_COLORS.get(body.kind, (128, 128, 128))
            objects.append(
                SceneObject(
                    body.name,
                    body.kind,
                    body.center_pose().copy(),
                    (float(body.size[0]), float(body.size[1]), float(body.size[2])),
                    (r / 255.0, g / 255.0, b / 255.0),
                    body.held,
                    None if body.marker is None else int(body.marker.id),
                    routes.get(body.name, []),
                )
            )
    return objects


__all__ = ["scene_objects"]
