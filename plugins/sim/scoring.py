"""The score of a simulated run: the ground truth a test, a sweep or the summary reads."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from .world_state import WorldState


def world_score(world: WorldState) -> dict[str, Any]:
    """Every body's place, what lies in a bin or on a Duckybot, collisions, missed steps
    and the Duckybots' tracking, as plain data (mm, degrees, seconds). Never for deciding.
    The caller holds the world's lock.
    """
    objects = {}
    in_bin = []
    for name, b in sorted(world.bodies.items()):
        where = world.in_bin(b)
        if where is not None:
            in_bin.append(name)
        objects[name] = {
            "kind": b.kind,
            "position_mm": b.pose[:3, 3].round(2).tolist(),
            "yaw_deg": round(math.degrees(b.yaw), 2),
            "on": b.support,
            "held": b.held,
            "in_bin": where,
            "marker": None if b.marker is None else b.marker.id,
        }
    on_bots = {
        name: sorted(c.name for c in world.carried_by(name, kinds=("ducky",)))
        for name in world.duckybots
    }
    trash = [n for n, b in world.bodies.items() if b.kind == "trash"]
    return {
        "time_s": round(world.time, 6),
        "objects": objects,
        "in_bin": in_bin,
        "trash_total": len(trash),
        "trash_in_bin": sum(1 for n in trash if n in in_bin),
        "duckies_on_duckybots": on_bots,
        "ducky_on_duckybot": any(on_bots.values()),
        "held": world.held,
        "fell_off_table": sorted(n for n, b in world.bodies.items() if b.off_table),
        "collision_count": len(world.collisions.log),
        "collisions": [dataclasses.asdict(c) for c in world.collisions.log],
        "duckybots": {
            name: {
                "pose": [
                    round(bot.state.x, 2),
                    round(bot.state.y, 2),
                    round(math.degrees(bot.state.theta), 2),
                ],
                "phase": bot.phase,
                "max_tracking_error_mm": round(bot.max_tracking_error, 3),
            }
            for name, bot in world.duckybots.items()
        },
        "missed_steps": [
            e.detail | {"time": round(e.time, 6)} for e in world.events if e.kind == "missed_steps"
        ],
        "events": len(world.events),
    }


def score_line(score: dict[str, Any]) -> str:
    """One line of a world's score for the run summary: ducky on a Duckybot, bins,
    collisions and what the gripper holds."""
    in_bin = ", ".join(score.get("in_bin") or ()) or "none"
    return " · ".join(
        (
            f"ducky on duckybot: {'yes' if score.get('ducky_on_duckybot') else 'no'}",
            f"in bin: {in_bin}",
            f"collisions: {score.get('collision_count', 0)}",
            f"held: {score.get('held') or 'none'}",
        )
    )
