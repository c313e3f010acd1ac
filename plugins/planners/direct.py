"""The ``direct`` planner: a straight joint-space move, validated before it is returned.

Pozzani 2023's motion algorithm: the target's inverse-kinematics solutions are
tried nearest-first (:meth:`armtree.api.rig.Planner.plan_to`), and each straight
move is validated (limits, collisions, singularity margin) before use.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import SimpleNamespace
from typing import Any, Protocol, TypeVar, cast

import numpy as np

from armtree.api.rig import Planner
from armtree.config.params import Param
from armtree.config.profile_access import profile_section
from armtree.errors import ConfigError
from armtree.loader.profile import Profile
from armtree.maths.motion.collision import CollisionChecker
from armtree.maths.motion.kinematics import KinematicModel
from armtree.maths.motion.scene import Scene
from armtree.maths.motion.start_contact import StartContactRecovery
from armtree.maths.motion.validation import check_config, validate_samples
from armtree.maths.motion.workspace import ArmWorkspace


class DirectPlanner(Planner):
    """Straight joint-space moves, refused with a reason when they are not safe.

    ``resolution`` is the largest joint step (deg / mm) between checked samples;
    ``min_singular`` the smallest allowed singular value of the Jacobian (mm/deg),
    or None to skip that check.
    """

    def __init__(
        self, checker: CollisionChecker, resolution: float = 2.0, min_singular: float | None = 0.2
    ) -> None:
        self.checker = checker
        self.model = checker.model
        self.resolution = float(resolution)
        self.min_singular = min_singular
        self.workspace = ArmWorkspace(self.model)
        self.start_contact = StartContactRecovery(checker)

    def plan(self, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """``[start, goal]`` ``(2, n)`` deg / mm, or PlanningError naming why not.

        A start in a shallow collision gets ``[start, free, goal]``: a short move
        out of the contact first (:class:`~armtree.maths.motion.start_contact.StartContactRecovery`).
        """
        start, escape = self.start_contact.check(start)
        if escape is not None:
            return self.start_contact.follow(self, escape, goal)
        goal = check_config(self.checker, goal, "goal", self.min_singular)
        # The start is where the arm already is: only the samples after it must keep the margin.
        samples = sample_segment(start, goal, self.resolution)[1:]
        validate_samples(self.checker, samples, self.min_singular).raise_if_bad()
        return np.stack([start, goal])

    def plan_to(self, start: np.ndarray, xyz: np.ndarray) -> np.ndarray:
        """Waypoints to a tool position (mm), IK solutions nearest-first (Pozzani 2023).

        A non-finite or unreachable target is refused (:class:`Unreachable`)
        before any inverse kinematics runs.
        """
        return super().plan_to(start, self.workspace.require(xyz))


def sample_segment(q0: np.ndarray, q1: np.ndarray, step: float) -> np.ndarray:
    """Configurations from ``q0`` to ``q1`` inclusive, no joint moving more than ``step`` between two."""
    n = max(1, int(np.ceil(np.abs(q1 - q0).max() / step)))
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
    return q0 + t * (q1 - q0)


def planner_checker(
    config: Mapping[str, Any], context: Any, model: KinematicModel | None, scene: Any
) -> CollisionChecker:
    """The collision checker a planner factory needs, with the arm's start checked.

    ConfigError without an arm model, and when the arm's home or its simulated
    power-up pose (the arm section's ``start_pose``) overlaps an obstacle.
    """
    if model is None:
        raise ConfigError(f"planner {config.get('type', '')!r} needs an arm: the profile has none")
    if not isinstance(scene, Scene):
        scene = Scene.from_profile({"obstacles": scene or []})
    margin = float(config.get("margin_mm", 0.0))
    checker = CollisionChecker(model, scene, margin=margin)
    profile = getattr(context, "profile", None)
    arm = profile_section(profile, "arm")
    start = arm.get("start_pose") if isinstance(arm, Mapping) else None
    starts = [(model.home, "home", "obstacles")]
    if start is not None and len(start) == model.dof:
        starts.append((start, "start (arm.start_pose)", "arm.start_pose"))
    for q, what, key in starts:
        q = np.asarray(q, dtype=float)
        try:
            checker.check_start(q, what)
        except ConfigError as exc:
            # profile is None: no error method either, so the ConfigError goes on as it is
            if profile is None or not callable(getattr(profile, "error", None)):
                raise
            # Name the key to change: the margin when the pose is clear without it.
            if margin > 0 and not CollisionChecker(model, scene).contacts(q):
                raise profile.error(
                    "planner.margin_mm",
                    f"{margin:g} mm is too wide: {exc.message}; give a smaller margin",
                ) from None
            raise profile.error(key, exc.message) from None
    return checker


def validate_start(config: Mapping[str, Any], profile: Profile) -> None:
    """Load-time check (``armtree check``): the arm's home and start pose clear the
    profile's obstacles with the planner's margin; ConfigError at the key to change."""
    arm = profile.component("arm") if "arm" not in profile.invalid else None
    if not arm:
        return
    manager = profile.manager
    if manager is None:
        from armtree.hooks.plugin_manager import get_plugin_manager

        manager = get_plugin_manager()
    build_model = getattr(manager.registry.get("arm", arm["type"]).factory, "model", None)
    if not callable(build_model):
        return
    try:
        model = build_model(arm)
    except (ConfigError, ValueError, TypeError, KeyError, IndexError, ArithmeticError):
        return  # the arm's own check reports it
    planner_checker(config, SimpleNamespace(profile=profile), model, Scene.from_profile(profile))


PlannerT_co = TypeVar("PlannerT_co", covariant=True)


class PlannerFactory(Protocol[PlannerT_co]):
    """A planner factory, ``factory(config, context, model, scene)``, with the members
    the loader reads off it: ``PARAMS`` and the load-time ``validate(config, profile)``.
    A plugin casts its factory function to it once its members are set (mypy types a
    ``def`` as a plain callable, which has no attributes to set)."""

    PARAMS: tuple[Param, ...]
    validate: Callable[[Mapping[str, Any], Profile], None]

    def __call__(
        self, config: Mapping[str, Any], context: Any, model: KinematicModel, scene: Any
    ) -> PlannerT_co: ...


def direct_factory(
    config: Mapping[str, Any], context: Any, model: KinematicModel, scene: Any
) -> DirectPlanner:
    """Straight joint-space moves, validated for limits, collisions and singularities."""
    checker = planner_checker(config, context, model, scene)
    min_sv = config.get("min_singular", 0.2)
    return DirectPlanner(checker, float(config.get("resolution_deg", 2.0)), min_sv)


# mypy types a def as a plain callable, which has no attributes to set: the same function,
# typed as what it is once the members below are set.
direct_factory = cast(PlannerFactory[DirectPlanner], direct_factory)
direct_factory.validate = validate_start


#: How finely a path is checked and with what clearance: the keys every checking planner takes.
CHECK_PARAMS = (
    Param(
        "resolution_deg",
        "float",
        2.0,
        "deg",
        "largest joint step between checked samples",
        minimum=0.05,
        maximum=45.0,
    ),
    Param(
        "margin_mm",
        "float",
        0.0,
        "mm",
        "clearance added around every link box",
        minimum=0.0,
        maximum=200.0,
    ),
)

direct_factory.PARAMS = (
    *CHECK_PARAMS,
    Param(
        "min_singular", "any", 0.2, "mm/deg", "smallest allowed Jacobian singular value, or null"
    ),
)
