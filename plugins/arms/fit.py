"""Does a profile written for one arm fit another? Checked when ``--set arm.type=X`` swaps it.

A profile's places, tool and camera mount were written for its arm. Swapping the
arm with one key keeps all of them, so before anything is built every one is
checked against the new arm: a place it cannot reach, a tool it does not grip
with, an eye-in-hand camera whose pose was given in a tool frame the new arm
does not have. Each misfit is a :class:`armtree.ConfigError` at the key's file,
line and column. Units: mm and degrees.
"""

from __future__ import annotations

import numpy as np

from armtree.errors import ConfigError
from armtree.loader.profile import Profile, Swap
from armtree.maths.motion.kinematics import KinematicModel
from armtree.maths.perception.frames import EYE_IN_HAND

#: Angle (degrees) between the two arms' tool z axes at home beyond which a camera
#: pose written in one tool frame points elsewhere on the other.
TOOL_FRAME_TOLERANCE_DEG = 45.0


def swapped_arm(profile: Profile) -> tuple[Swap, KinematicModel] | None:
    """The arm swap in ``profile`` and the new arm's model, or None when the arm was not swapped.

    Raises :class:`ConfigError` at ``arm.type`` when the new arm's model cannot be
    built from what the profile gives it.
    """
    swap = getattr(profile, "swaps", {}).get("arm") if isinstance(profile, Profile) else None
    if swap is None:
        return None
    config = profile.component("arm") or {}
    factory = profile.registry.get("arm", config["type"]).factory
    make = getattr(factory, "model", None)
    if make is None:
        return None
    try:
        return swap, make(config)
    except (ConfigError, ValueError, TypeError, KeyError) as exc:
        raise profile.error("arm.type", f"{config['type']}: {_message(exc)}") from None


def reachable(model: KinematicModel, points: np.ndarray) -> np.ndarray:
    """Boolean per point ``(N, 3)``: some inverse-kinematics solution within the limits."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    sols = model.ik_all(points)
    return np.any(np.all(np.isfinite(sols), axis=-1), axis=-1)


def why(profile: Profile, swap: Swap) -> str:
    """The clause every misfit ends with: what was swapped for what, and the way out."""
    new = profile.data["arm"]["type"]
    return (
        f"(the profile was written for {swap.previous}; --set arm.type={new}): change it for "
        f"{new} or use a profile written for it"
    )


def swap_misfits(profile: Profile) -> list[ConfigError]:
    """Every key of a profile whose arm was swapped that does not fit the new arm.

    Places out of the new arm's reach, a declared tool it does not grip with, and
    an eye-in-hand camera whose tool frame turned; empty when nothing was swapped.
    """
    try:
        found = swapped_arm(profile)
    except ConfigError as exc:
        return [exc]
    if found is None:
        return []
    swap, model = found
    return [
        *_places(profile, swap, model),
        *_tool(profile, swap),
        *_camera(profile, swap, model),
    ]


def _places(profile: Profile, swap: Swap, model: KinematicModel) -> list[ConfigError]:
    places = profile.places()
    if not places:
        return []
    ok = reachable(model, np.array(list(places.values())))
    new = profile.data["arm"]["type"]
    return [
        profile.error(
            f"places.{name}",
            f"{np.round(xyz, 1).tolist()} mm is out of reach of {new} {why(profile, swap)}",
        )
        for (name, xyz), fine in zip(places.items(), ok, strict=True)
        if not fine
    ]


def _tool(profile: Profile, swap: Swap) -> list[ConfigError]:
    """The tool the file declares (``arm.tool``, kept or dropped) against the new arm's."""
    config = profile.component("arm") or {}
    factory = profile.registry.get("arm", config["type"]).factory
    grips = getattr(factory, "grips_with", None)
    if grips is None:
        return []
    if "tool" in swap.dropped:
        wanted, mark = swap.dropped["tool"]
    elif (profile.data["arm"] or {}).get("tool") is not None:
        wanted, mark = profile.data["arm"]["tool"], profile.mark("arm.tool")
    else:
        return []
    has = grips(config)
    if wanted == has:
        return []
    new = config["type"]
    message = f"arm.tool: {wanted}: {new} grips with {has or 'nothing'} here {why(profile, swap)}"
    if mark is None:
        return [profile.error("arm.tool", message)]
    return [ConfigError(message, mark.file, mark.line, mark.column)]


def _camera(profile: Profile, swap: Swap, model: KinematicModel) -> list[ConfigError]:
    """An eye-in-hand camera's pose is given in the tool frame of the arm it was written for."""
    camera = profile.data.get("camera") or {}
    if camera.get("mount") != EYE_IN_HAND:
        return []
    registry = profile.registry
    old = registry.get("arm", swap.previous).factory if registry.has("arm", swap.previous) else None
    make = getattr(old, "model", None)
    if make is None:
        return []
    old_config = {**(profile.data["arm"] or {}), "type": swap.previous}
    old_config.update({k: v for k, (v, _) in swap.dropped.items()})
    try:
        old_model = make(old_config)
    except (ConfigError, ValueError, TypeError, KeyError):
        return []
    z_old = old_model.fk(old_model.home)[:3, 2]
    z_new = model.fk(model.home)[:3, 2]
    angle = float(np.degrees(np.arccos(np.clip(np.dot(z_old, z_new), -1.0, 1.0))))
    if angle <= TOOL_FRAME_TOLERANCE_DEG:
        return []
    new = profile.data["arm"]["type"]
    return [
        profile.error(
            "camera.mount",
            f"eye_in_hand: the camera's pose is given in {swap.previous}'s tool frame, whose z "
            f"axis {new}'s turns by {angle:.0f} degrees at home; the camera would look "
            f"elsewhere {why(profile, swap)}",
        )
    ]


def _message(exc: BaseException) -> str:
    return exc.message if isinstance(exc, ConfigError) else str(exc)
