"""Where a skill lets go in a bin: :func:`~.bins.plan_drop` over what the run let go
there and what the camera last saw inside it. Base frame, mm."""

from __future__ import annotations

import contextlib

import numpy as np

from armtree.api.rig import needed
from armtree.api.skill.actions import SkillFailure
from armtree.api.skill.arm import ArmSkill
from armtree.api.skill.base import as_list
from armtree.api.skill.eye import eye_of

from .bins import Drop, contents_of, inside, plan_drop
from .grip import tool_pose_at


def bin_drop(
    skill: ArmSkill,
    name: str,
    place: np.ndarray,
    held: np.ndarray | None,
    hang: float,
    role: str,
    marker: int | None,
) -> Drop:
    """Where to let go in the bin at place ``name``: :func:`~.bins.plan_drop` over what
    this run let go there and the markers last seen inside it (not the held ``marker``).

    ``held``: the held marker in the tool frame (None: at the tool centre); ``hang``: how
    far the held object reaches below the tool (mm); ``role``: its tag role. Raises
    :class:`SkillFailure`, still holding, when no reachable release clears what is there.
    """
    rig = skill.rig
    spec = skill.workcell.bins[name]
    contents = contents_of(skill.bb).of(name)
    view = eye_of(rig).last
    if view is not None:
        contents += [
            s.position for s in view.sightings if s.id != marker and inside(spec, place, s.position)
        ]
    tag = rig.tags.get(role) if role else None
    offset = None
    if held is not None:
        with contextlib.suppress(ValueError):  # the place's IK (Unreachable)
            offset = (tool_pose_at(rig, place) @ held)[:2] - place[:2]
    drop = plan_drop(
        needed(rig.arm, "arm").model,
        place,
        spec,
        contents,
        hang,
        tag.size_mm if tag is not None else 0.0,
        offset,
    )
    if drop is None:
        raise SkillFailure(
            f"{skill.name}: no room left in {name!r} within reach: the held object would "
            f"not clear its rim or the {len(contents)} thing(s) in it; still holding it"
        )
    skill.note(
        "bin_drop",
        bin=name,
        landing_mm=as_list(drop.landing),
        tool_mm=as_list(drop.tool),
        room_mm=None if np.isinf(drop.room_mm) else round(drop.room_mm, 1),
        contents=len(contents),
    )
    return drop


__all__ = ["bin_drop"]
