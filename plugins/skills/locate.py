"""Finding a tag before acting on it: look where it should be, look around, look again closer.

A place in a profile is where to look, not where a thing is (Showers 2016's
"Loading a ducky" relied on static positions and frequent touch tests; here
the camera decides). :func:`locate` brings the camera over the hint, looks
around it within the profile's ``workcell.search_radius_mm`` when the tag is not
in view, and measures the tag once more from above it, closer where the arm
reaches, before anyone grips or releases there. mm, base frame.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from armtree.api.rig import Rig, needed
from armtree.api.skill.actions import Look, Move
from armtree.api.skill.arm import ArmSkill, camera_over
from armtree.api.skill.base import ActionFailed, Procedure
from armtree.api.skill.eye import Sighting, Tally, eye_of
from armtree.api.skill.sightline import out_of_view
from armtree.maths.perception.frames import EYE_IN_HAND

#: Fewest points of a ring looked at around a hint when the tag is not in view over it.
AROUND = 6
#: Spacing of those points, as a fraction of the camera's view on the table.
OVERLAP = 0.8
#: Most camera poses a look-around may take.
MAX_LOOKS = 24
#: A closer look is this fraction of the survey's camera height.
CLOSER = 0.6
#: Frames averaged when a tag is measured again before acting on it.
REFINE_FRAMES = 3


@dataclass
class Found:
    """Where :func:`locate` found a tag (None), from how many camera poses it looked, and
    what its looks saw (:class:`Tally`)."""

    sighting: Sighting | None
    looks: int
    tally: Tally = field(default_factory=Tally)

    def not_found(self, rig: Rig) -> str:
        """Why the tag was not found, for a failure's parentheses: the poses looked from and
        what the frames showed (markers of another family, other tags, nothing)."""
        family = getattr(rig.tracker, "marker_family", None)
        return f"looked from {self.looks} camera poses; {self.tally.describe(family)}"

    @property
    def position(self) -> np.ndarray:
        """The tag's measured position (mm); only when found."""
        assert self.sighting is not None
        return self.sighting.position


def look_over(
    skill: ArmSkill,
    point: np.ndarray | None,
    height: float,
    want: str | None,
    frames: int = 3,
    average: bool = False,
    tally: Tally | None = None,
) -> Procedure:
    """Bring the camera ``height`` mm above ``point`` (stay put if None) and look.

    Eye-to-hand the arm does not move (the camera is not on it). Returns the list
    of :class:`Sighting`, positions averaged over the frames when ``average``; the
    frames are added to ``tally`` when given.
    """
    rig = skill.rig
    if point is not None and needed(rig.camera, "camera").mount == EYE_IN_HAND:
        tool = camera_over(skill, point, height)
        yield Move(rig, tool, speed=skill.speed(), label="look over")
    look = Look(
        rig,
        skill.clock,
        want=want,
        frames=frames,
        settle=skill.settle(),
        average=average,
        tally=tally,
    )
    return (yield look)


def nearest(
    sightings: list[Sighting],
    role: str,
    near: np.ndarray | None,
    radius: float | None = None,
    skip: Iterable[int] = (),
) -> Sighting | None:
    """The sighting of ``role`` nearest to ``near`` (mm, in the xy plane), within ``radius``
    if given, ignoring marker ids in ``skip``."""
    skipped = set(skip)
    cands = [s for s in sightings if s.role == role and s.id not in skipped]
    if not cands:
        return None
    if near is None:
        return cands[0]
    dist = [float(np.linalg.norm(s.position[:2] - near[:2])) for s in cands]
    best = int(np.argmin(dist))
    if radius is not None and dist[best] > radius:
        return None
    return cands[best]


def around(hint: np.ndarray, radius: float, view: tuple[float, float] | None) -> list[np.ndarray]:
    """Points to bring the camera over when a tag is not in view over ``hint``.

    The first ring is half the camera's smaller view size (``view``, mm on the
    table; None: unknown) from the hint, so the hint stays in view, off the image
    centre that a held object or the tool may hide; further rings ``OVERLAP`` of
    the view apart until they cover the disc of ``radius``, each ring's points as
    far apart; at most :data:`MAX_LOOKS`, nearest first.
    """
    size = min(view) if view is not None and min(view) > 1.0 else radius
    spacing = OVERLAP * size
    out: list[np.ndarray] = []
    r = 0.5 * size
    while r < radius + 0.5 * spacing and len(out) < MAX_LOOKS:
        count = max(AROUND, math.ceil(2.0 * math.pi * r / spacing))
        for a in np.linspace(0.0, 2.0 * math.pi, count, endpoint=False):
            out.append(hint + np.array([r * math.cos(a), r * math.sin(a), 0.0]))
        r += spacing
    return out[:MAX_LOOKS]


def locate(
    skill: ArmSkill,
    tag: str,
    hint: np.ndarray | None,
    radius: float,
    skip: Iterable[int] = (),
    refine: bool = True,
) -> Procedure:
    """Find tag role ``tag`` within ``radius`` mm of ``hint`` (anywhere in view if None).

    Eye-in-hand: the camera looks over the hint, then over :func:`around` points;
    eye-to-hand: from where the arm is, then with the arm at the survey pose
    farthest from the hint. With ``refine`` the tag found is measured again over
    its own position, closer where the arm reaches, averaging a few frames.
    Returns a :class:`Found`.
    """
    rig, cell = skill.rig, skill.workcell
    height = cell.look_height_mm
    skip = tuple(skip)
    in_hand = needed(rig.camera, "camera").mount == EYE_IN_HAND
    tries: list[np.ndarray | None] = [hint]
    if not in_hand:
        far = out_of_view(skill, hint) if hint is not None else None
        tries = [None] if far is None else [None, far]
    seen: Sighting | None = None
    looks = 0
    tally = Tally()
    while tries:
        point = tries.pop(0)
        looks += 1
        if in_hand or point is None:
            sightings = yield from look_over(skill, point, height, tag, frames=2, tally=tally)
        else:
            yield Move(rig, point, speed=skill.speed(), label="out of view")
            sightings = yield from look_over(skill, None, height, tag, frames=2, tally=tally)
        seen = nearest(sightings, tag, hint, radius if hint is not None else None, skip)
        if seen is not None:
            break
        if in_hand and hint is not None and looks == 1:
            view = eye_of(rig).last
            tries = [
                *around(hint, radius, None if view is None else view.footprint(float(hint[2])))
            ]
    if seen is None or not refine:
        return Found(seen, looks, tally)
    # measure again from over the tag itself (nearer the image centre, less distortion),
    # closer where the arm reaches, averaging frames
    closer = height * CLOSER if in_hand else height
    again = yield from look_over(skill, seen.position, closer, None, REFINE_FRAMES, average=True)
    best = nearest(again, tag, seen.position, radius / 2.0, skip)
    return Found(best if best is not None else seen, looks + 1, tally)


def move_out_of_view(skill: ArmSkill, point: np.ndarray) -> Procedure:
    """Eye-to-hand: take the arm to where it hides ``point`` least (a refused move stays put)."""
    clear = out_of_view(skill, point)
    if clear is None:
        return
    with contextlib.suppress(ActionFailed):
        yield Move(skill.rig, clear, speed=skill.speed(), label="out of view")


def skipped(value: Any) -> list[int]:
    """Marker ids from a ``skip`` parameter's value (None or a list)."""
    return [int(v) for v in value] if isinstance(value, (list, tuple)) else []


__all__ = [
    "Found",
    "around",
    "locate",
    "look_over",
    "move_out_of_view",
    "nearest",
    "skipped",
]
