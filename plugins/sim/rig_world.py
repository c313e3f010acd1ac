"""The world behind a rig: built from the profile, stepped after the emulators.

:func:`attach_world` is what the sim plugin's ``armtree_rig_ready`` and
``armtree serve-sim`` do to a rig: build the world from the profile's
``world:`` section, put the arm emulator (with the as-built arm) into it and
append the :class:`WorldStepper`. :func:`sim_world` finds the world of a run
again, for the hooks that judge it, tests and benchmarks; skills never see it.
"""

from __future__ import annotations

from typing import Any

from armtree.api.emulation import SHARED_KEY as EMULATOR_KEY
from armtree.api.rig import Rig
from armtree.config.profile_access import profile_section
from armtree.loader.profile import Profile
from armtree.runtime.runner import Run

from .as_built import SimMeasuringDevice
from .camera import SimCamera
from .recording import Recorder
from .scene import body_error
from .world import World, world_for


class WorldStepper:
    """The per-tick stepper of a world; the run hooks find the world through it.

    It sits in the rig's steppers, which a skill is handed with the rig, so it keeps
    the world, the camera and the recorder to itself: what judges a run gets the
    world through :func:`sim_world`, which a skill cannot import.
    """

    def __init__(self, world: World, camera: SimCamera | None) -> None:
        self._world = world
        self._camera = camera
        self._recorder: Recorder | None = None

    def __call__(self, now: float) -> None:
        self._world.step(now)
        if self._recorder is not None:
            self._recorder.step(now)


def uses_sim(profile: Profile) -> bool:
    """True when the profile has a ``world:`` section, an arm on ``port: sim`` or a sim camera."""
    arm = profile_section(profile, "arm") or {}
    camera = profile_section(profile, "camera") or {}
    return (
        profile_section(profile, "world") is not None
        or (isinstance(arm, dict) and arm.get("port") == "sim")
        or (isinstance(camera, dict) and camera.get("type") == "sim")
    )


def sim_world(run: Run) -> World | None:
    """The simulated world of a run (or of a served bench), for judging it; None off the sim.

    For tests, benchmarks and the sim's own hooks: skills never see it.
    """
    stepper = world_stepper(run)
    return None if stepper is None else stepper._world


def world_stepper(run: Run) -> WorldStepper | None:
    """The world stepper among the run's rig steppers, or None off the sim."""
    rig = getattr(run, "rig", None)
    for stepper in getattr(rig, "steppers", None) or ():
        if isinstance(stepper, WorldStepper):
            return stepper
    return None


def attach_world(rig: Rig, context: Any) -> None:
    """Build the world from the profile (when it uses a sim part), attach the emulated arm,
    and step the world after the emulators; a second call changes nothing."""
    if not uses_sim(context.profile):
        return
    if any(isinstance(s, WorldStepper) for s in context.steppers):
        return
    world = world_for(context)
    emulator = context.shared.get(EMULATOR_KEY)
    if emulator is not None and world.emulator is None:
        world.attach_arm(emulator, as_built_model(context.profile, world.scene.as_built.arm))
        for link, body in world.start_overlaps():
            spec = world.bodies[body].spec
            raise body_error(
                context.profile, spec, f"{body} is inside the arm's {link} at its start pose"
            )
    camera = rig.camera if isinstance(rig.camera, SimCamera) else None
    context.steppers.append(WorldStepper(world, camera))
    if rig.reference is None:
        rig.reference = SimMeasuringDevice(
            world, world.scene.as_built.reference_noise_mm, seed=context.seed
        )


def arm_factory(profile: Profile) -> Any:
    """The registered component of the profile's arm type, or None."""
    arm = profile_section(profile, "arm") or {}
    manager = getattr(profile, "manager", None)
    if manager is None or not manager.registry.has("arm", arm.get("type", "")):
        return None
    return manager.registry.get("arm", arm["type"])


def as_built_model(profile: Profile, changes: dict[str, Any]) -> Any:
    """The arm's kinematic model with ``world.as_built.arm`` laid over the profile's keys;
    None when the arm is as the profile says."""
    component = arm_factory(profile)
    make = getattr(getattr(component, "factory", None), "model", None)
    if not changes or not callable(make):
        return None
    return make({**(profile.component("arm") or {}), **changes})


__all__ = [
    "WorldStepper",
    "arm_factory",
    "as_built_model",
    "attach_world",
    "sim_world",
    "uses_sim",
    "world_stepper",
]
