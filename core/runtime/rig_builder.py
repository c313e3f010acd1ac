"""Building a :class:`~armtree.api.rig.Rig` from a validated hardware profile.

Components come from the plugin registry by ``type``: ``factory(config,
context)`` for the arm, camera and tracker, ``factory(config, context, model,
scene)`` for the planner (``model`` is the arm driver's kinematic model,
``scene`` what :mod:`armtree.maths.motion.scene` makes of the profile's obstacles, or the raw
``obstacles`` list when that module is absent). Then the ``armtree_rig_ready``
hook lets plugins wire components together (a plugin may set ``rig.tool``; else
the arm's own :class:`~armtree.api.rig.ArmTool`, when it has a tool), the context's
steppers and closers move into the rig, and :meth:`Rig.start` starts the components in
:data:`armtree.api.rig.START_ORDER` (the arm connects, the camera opens). If
anything fails, whatever was built is closed (:meth:`Rig.close`: components in
reverse start order, then the closers) before the error propagates.
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Callable, Mapping
from typing import Any

from armtree.api.clock import Clock
from armtree.api.rig import ArmTool, Rig, RigContext, TagSpec
from armtree.api.views import ProfileView
from armtree.config.profile_access import component_config, profile_section, profile_source
from armtree.errors import ConfigError, HardwareFault
from armtree.hooks.hook_calls import plugin_failure
from armtree.hooks.plugin_manager import PluginManager, Registry, get_plugin_manager
from armtree.loader.profile import arm_grips, tag_spec

#: Profile sections that name a component, in build order.
COMPONENT_SECTIONS: tuple[str, ...] = ("arm", "camera", "tracker")
#: Sections that may stand for a physical device (the rest is software).
DEVICE_SECTIONS: tuple[str, ...] = ("arm", "camera")


def uses_real_hardware(profile: ProfileView, registry: Registry | None = None) -> bool:
    """True when the profile drives a physical device, so the run must keep the wall clock.

    Each arm or camera factory says so itself: ``factory.simulated(config)`` is
    True when that config runs on no device (an emulator, a renderer). A factory
    that does not say is taken to be a device when it is a camera or its config
    names a ``port`` or ``device``. ``registry`` defaults to the profile's plugins'.
    """
    if registry is None:
        manager = getattr(profile, "manager", None) or get_plugin_manager()
        registry = manager.registry
    for key in DEVICE_SECTIONS:
        section = profile_section(profile, key)
        if not isinstance(section, Mapping) or not section:
            continue
        kind = key
        name = str(section.get("type") or "")
        factory = registry.get(kind, name).factory if registry.has(kind, name) else None
        simulated = getattr(factory, "simulated", None)
        if callable(simulated):
            if not simulated(dict(section)):
                return True
        elif key == "camera" or "port" in section or "device" in section:
            return True
    return False


def make_scene(profile: ProfileView) -> Any:
    """The planning scene of a profile: :mod:`armtree.maths.motion.scene`'s if present, else raw obstacles."""
    obstacles = profile_section(profile, "obstacles") or []
    if importlib.util.find_spec("armtree.maths.motion.scene") is None:
        return obstacles
    scene_module = importlib.import_module("armtree.maths.motion.scene")
    scene_cls = getattr(scene_module, "Scene", None)
    if scene_cls is not None and hasattr(scene_cls, "from_profile"):
        return scene_cls.from_profile(profile)
    factory = getattr(scene_module, "scene_from_profile", None)
    if callable(factory):
        return factory(profile)
    return obstacles


def parse_tags(tags: Any, file: str | None = None, family: str | None = None) -> dict[str, TagSpec]:
    """``tags:`` of a profile (``{role: {id: N | ids: [...], size_mm: S}}``) as TagSpecs,
    their ``ids`` those of marker family ``family`` (``family_ids``) where the profile gives them."""
    found: dict[str, TagSpec] = {}
    for role, spec in (tags or {}).items():
        if isinstance(spec, TagSpec):
            found[role] = spec.in_family(family)
            continue
        if not isinstance(spec, Mapping) or "size_mm" not in spec:
            raise ConfigError(f"tags.{role}: give id or ids, and size_mm", file=file)
        found[role] = tag_spec(str(role), spec).in_family(family)
    return found


def build_rig(
    profile: ProfileView,
    manager: PluginManager,
    clock: Clock,
    *,
    seed: int = 0,
    interrupt: Callable[[str, HardwareFault | None], None] | None = None,
    record_dir: Any = None,
) -> Rig:
    """Build and start every component the profile names; see the module docstring.

    Raises :class:`ConfigError` for an unknown component type and lets a
    factory's or a start's :class:`HardwareFault` through, after closing what
    was built.
    """
    file = profile_source(profile)
    context = RigContext(profile=profile, clock=clock, seed=seed, record_dir=record_dir)
    if interrupt is not None:
        context.interrupt = interrupt
    rig = Rig(profile=profile, clock=clock)
    registry = manager.registry
    try:
        for key in COMPONENT_SECTIONS:
            config = component_config(profile, key)
            if not config:
                continue
            component = _component(registry, key, config, file)
            made = _made(component, profile, key, dict(config), context)
            setattr(rig, key, made)
        planner_config = component_config(profile, "planner")
        if planner_config:
            component = _component(registry, "planner", planner_config, file)
            model = rig.arm.model if rig.arm is not None else None
            scene = make_scene(profile)
            args = (dict(planner_config), context, model, scene)
            rig.planner = _made(component, profile, "planner", *args)
        # the ids skills and calibrations act on are those of the markers the tracker reads
        # (a tracker that does not subclass Tracker names no family)
        family = getattr(rig.tracker, "marker_family", None)
        rig.tags = parse_tags(profile_section(profile, "tags"), file, family)
        rig.places = {k: list(v) for k, v in (profile_section(profile, "places") or {}).items()}
        manager.hook.armtree_rig_ready(rig=rig, context=context)
        if rig.tool is None and rig.arm is not None and arm_grips(registry, profile) is not None:
            rig.tool = ArmTool(rig.arm)
        rig.steppers.extend(context.steppers)
        rig.closers.extend(context.closers)
        context.steppers = rig.steppers
        context.closers = rig.closers
    except BaseException:
        rig.closers.extend(c for c in context.closers if c not in rig.closers)
        rig.close()
        raise
    rig.start()
    return rig


def _component(registry: Registry, kind: str, config: Any, file: str | None) -> Any:
    if not isinstance(config, Mapping) or "type" not in config:
        raise ConfigError(f"{kind}: a mapping with a 'type' is required", file=file)
    return registry.get(kind, config["type"])


def _made(component: Any, profile: ProfileView, key: str, *args: Any) -> Any:
    """``component.factory(*args)``; a plugin's exception other than a hardware fault or a refusal
    of its configuration is the plugin's error, at the line it raised, before anything moves."""
    try:
        return component.factory(*args)
    except (ConfigError, HardwareFault, KeyboardInterrupt):
        raise
    except OSError as exc:
        if exc.filename is not None:
            raise  # a path the profile gave, reported as such
        raise plugin_failure(_what(component, profile, key), component, exc) from exc
    except Exception as exc:  # noqa: BLE001 - a plugin's bug, named as such
        raise plugin_failure(_what(component, profile, key), component, exc) from exc


def _what(component: Any, profile: ProfileView, key: str) -> str:
    mark = profile.mark(f"{key}.type") if hasattr(profile, "mark") else None
    named = f" (named at {mark})" if mark else ""
    return f"{component.kind} {component.name!r}{named}: its factory"
