"""The built-in simulation plugin: the ``sim`` camera and the world behind ``port: sim``.

``armtree_rig_ready`` builds the world from the profile's ``world:`` section
(when the profile uses any sim part), puts the arm emulator into it and
appends the world's stepper after the emulators'. ``armtree_run_started``
starts the recordings when the run records to a directory, and
``armtree_run_finished`` writes the ground-truth score beside the run log
and adds a one-line score to the run summary (``result.details``).
``armtree_run_started`` also hands the world's events to the run as they happen
(collisions, drops, missed steps: ``run.report_event``) and ends the run on a
collision under ``halt_on_collision`` (``run.fail``); ``armtree_ground_truth``
and ``armtree_world_inventory`` give the ``expect:`` predicates the world at the
end of a run and the nominal world while a tree loads (with what ``parked`` and
``tool_within_mm`` read: the Duckybots' phases, the tool and the marker centres).
The world lives in ``RigContext.shared`` only; the Rig never holds it.
``armtree_profile_sections`` registers the ``world:`` section, declared in
``world_spec.WORLD`` (its JSON Schema and key tables come from there), whose check
parses the world while the profile loads, so ``armtree check`` reports what
building the world would refuse.
"""

from __future__ import annotations

from typing import Any

import armtree
from armtree.api.rig import Rig
from armtree.config.params import check_value
from armtree.config.profile_access import profile_error, profile_section
from armtree.config.profile_sections import ProfileSection
from armtree.loader.profile import Profile
from armtree.runtime.runner import Run

from .bodies import WorldEvent
from .camera import sim_camera
from .recording import Recorder, write_score
from .rig_world import arm_factory, as_built_model, attach_world, uses_sim, world_stepper
from .scene import parse_scene
from .scene_spec import SceneSpec
from .scoring import score_line
from .serve import ServeSimCommand
from .truth import scene_truth, world_truth
from .view import scene_objects
from .world import World
from .world_spec import BASE_FAULTS, WORLD

#: Profile sections the world is parsed from; when one is already invalid the world is not.
_WORLD_INPUTS = frozenset({"world", "tags", "tracker", "obstacles", "table"})


def _table_disagrees(profile: Profile, scene: SceneSpec) -> list[armtree.ConfigError]:
    """The planning ``table:`` must be the simulated table top (``world.table.height``)."""
    table = profile_section(profile, "table")
    z = table.get("z") if isinstance(table, dict) else table
    if z is None or abs(float(z) - scene.table.height) <= 1e-6:
        return []
    return [
        profile.error(
            "table",
            f"the table top z = {z:g} mm differs from the simulated table's height "
            f"{scene.table.height:g} mm (world.table.height): give both the same height",
        )
    ]


@armtree.hookimpl
def armtree_cameras() -> dict[str, Any]:
    """The ``sim`` camera."""
    return {"sim": sim_camera}


@armtree.hookimpl
def armtree_commands() -> dict[str, Any]:
    """``armtree serve-sim``: the world served as a bench (arm on a pty, camera over HTTP)."""
    return {"serve-sim": ServeSimCommand}


@armtree.hookimpl
def armtree_profile_sections() -> dict[str, ProfileSection]:
    """The ``world:`` section: the simulated table, objects, Duckybot and faults, its
    schema and checks read from its declaration (``world_spec.WORLD``)."""
    return {"world": ProfileSection(schema=WORLD.schema(), check=check_world, spec=WORLD)}


def check_world(profile: Profile) -> list[armtree.ConfigError]:
    """Check ``world:`` as building the rig would, before anything is built.

    Reports objects off the table or inside each other, markers clashing with
    ``tags:``, unknown keys, and a planning ``table:`` that is not the simulated
    table top. A profile that uses a sim part without ``world:`` gets the default
    world, which is checked the same way.
    """
    if not uses_sim(profile) or getattr(profile, "invalid", frozenset()) & _WORLD_INPUTS:
        return []
    try:
        scene = parse_scene(profile)
    except armtree.ConfigError as exc:
        return list(exc.errors)
    return [
        *_table_disagrees(profile, scene),
        *_joints_exist(profile, scene),
        *_faults_taken(profile, scene),
        *_as_built_errors(profile, scene),
    ]


def _faults_taken(profile: Profile, scene: SceneSpec) -> list[armtree.ConfigError]:
    """``world.faults`` must be faults the arm's emulator takes (its factory's ``faults``)."""
    component = arm_factory(profile)
    taken = getattr(getattr(component, "factory", None), "faults", BASE_FAULTS)
    arm = (profile_section(profile, "arm") or {}).get("type")
    return [
        profile_error(
            profile,
            f"world.faults.{name}",
            f"the {arm} arm's emulator does not take this fault (it takes: {', '.join(taken)})",
        )
        for name in scene.faults
        if component is not None and name not in taken
    ]


def _joints_exist(profile: Profile, scene: SceneSpec) -> list[armtree.ConfigError]:
    """Joints named by ``world.faults.missed_steps`` must be joints of the profile's arm."""
    arm = profile_section(profile, "arm") or {}
    manager = getattr(profile, "manager", None)
    if manager is None or not manager.registry.has("arm", arm.get("type", "")):
        return []
    make = getattr(manager.registry.get("arm", arm["type"]).factory, "model", None)
    try:
        dof = make(profile.component("arm")).dof if callable(make) else None
    except (armtree.ConfigError, ValueError, TypeError, KeyError):
        return []  # the arm's own checks report it
    if dof is None:
        return []
    path = "world.faults.missed_steps"
    wanted = [("joint", scene.faults.get("missed_steps", {}).get("joint"))]
    if scene.slips is not None:
        wanted += [("joints", j) for j in scene.slips.joints]
    return [
        profile_error(
            profile,
            f"{path}.{key}",
            f"joint {int(j)} does not exist: the {arm['type']} arm has joints 0 to {dof - 1}",
        )
        for key, j in wanted
        if j is not None and int(j) >= dof
    ]


@armtree.hookimpl
def armtree_rig_ready(rig: Rig, context: Any) -> None:
    """Build the world, attach the emulated arm, and step the world after the emulators."""
    attach_world(rig, context)


def _as_built_errors(profile: Profile, scene: SceneSpec) -> list[armtree.ConfigError]:
    """``world.as_built.arm`` must name the arm type's own keys with values it takes."""
    changes = scene.as_built.arm
    component = arm_factory(profile)
    if not changes or component is None:
        return []
    known = {p.name: p for p in component.params}
    out = []
    for key, value in changes.items():
        path = f"world.as_built.arm.{key}"
        if key not in known:
            out.append(
                profile_error(
                    profile, path, f"the {profile.data['arm']['type']} arm has no key {key!r}"
                )
            )
            continue
        try:
            check_value(known[key], value)
        except ValueError as exc:
            out.append(profile_error(profile, path, str(exc)))
    if not out:
        try:
            as_built_model(profile, changes)
        except (armtree.ConfigError, ValueError, TypeError) as exc:
            out.append(profile_error(profile, "world.as_built.arm", f"no arm is built so: {exc}"))
    return out


#: World events shown to the user (the rest only go to the run log), and how.
_NOTABLE = {
    "collision": lambda d: f"collision: {d['link']} hit {d['other']} {d['depth_mm']:.1f} mm deep",
    "drop": lambda d: f"drop: {d['object']} fell {d['fall_mm']:.0f} mm onto {d['on']}",
    "missed_steps": lambda d: (
        f"missed steps: joint {d['joint']} slipped by {d['amount']:.2f} {d.get('unit', 'deg')}"
    ),
}


def _forward_events(run: Run, world: World) -> None:
    """Send the world's events to the run's log (and the notable ones to its view)."""

    report = getattr(run, "report_event", None)
    if report is None:  # a run object from before events (or a stand-in)
        return

    def forward(event: WorldEvent) -> None:
        show = _NOTABLE.get(event.kind)
        report(event.kind, show(event.detail) if show else None, **event.detail)

    world.listeners.append(forward)
    world.on_halt = run.fail
    for fault, options in world.scene.faults.items():
        text = ", ".join(f"{k} {v:g}" for k, v in options.items())
        run.report_event("fault", f"fault injected: {fault} {text}".strip(), fault=fault, **options)


@armtree.hookimpl
def armtree_run_started(run: Run) -> None:
    """Forward the world's events to the run; start recording videos when the run was
    given a record directory (``--record DIR``)."""
    stepper = world_stepper(run)
    if stepper is None:
        return
    if not stepper._world.listeners:
        _forward_events(run, stepper._world)
    if stepper._recorder is not None:
        return
    directory = getattr(run, "record_dir", None)
    if not run.record_requested or directory is None:
        return
    rig = run.rig
    assert rig is not None  # the world stepper is one of the rig's
    stepper._recorder = Recorder(directory, stepper._world, stepper._camera, rig.planner)
    rig.closers.append(stepper._recorder.close)


@armtree.hookimpl
def armtree_scene_objects(run: Run) -> list[Any] | None:
    """The world's table and bodies as boxes, for monitors and recordings."""
    stepper = world_stepper(run)
    return None if stepper is None else scene_objects(stepper._world)


@armtree.hookimpl
def armtree_world_inventory(profile: Profile) -> Any:
    """The profile's nominal world, for checking the names of a tree's ``expect:``."""
    if not uses_sim(profile):
        return None
    try:
        return scene_truth(parse_scene(profile), profile)
    except armtree.ConfigError:
        return None


@armtree.hookimpl
def armtree_ground_truth(run: Run) -> Any:
    """The world at the end of the run, once what was falling has landed."""
    stepper = world_stepper(run)
    if stepper is None:
        return None
    assert run.rig is not None  # the world stepper is one of the rig's
    stepper._world.settle()
    return world_truth(stepper._world, run.rig.profile)


@armtree.hookimpl
def armtree_run_finished(run: Run, result: Any) -> None:
    """Write the world's score (``score.json``) beside the run log and finish recordings."""
    stepper = world_stepper(run)
    if stepper is None:
        return
    score = stepper._world.score()
    score["run"] = {
        "status": getattr(result, "status", None),
        "ticks": getattr(result, "ticks", None),
        "seconds": getattr(result, "seconds", None),
        "wall_seconds": getattr(result, "wall_seconds", None),
    }
    log_path = getattr(result, "log_path", None)
    recorder = stepper._recorder
    score_path = None
    if log_path is not None:
        score_path = log_path.parent / "score.json"
    elif recorder is not None:
        score_path = recorder.directory / "score.json"
    errors = getattr(run, "record_errors", [])
    if score_path is not None:
        try:
            write_score(score, score_path)
        except OSError as exc:
            errors.append(f"{score_path.name}: {exc.strerror or exc}")
            score_path = None
    if recorder is not None:
        recorder.finish()
        errors.extend(recorder.errors)
    details = getattr(result, "details", None)
    if isinstance(details, dict):
        details["score"] = score_line(score)
        if score_path is not None:
            details["score file"] = str(score_path)
