"""Checks that a plugin's components fit the interfaces armtree calls them through.

Two depths:

* :func:`interface_problems`, run when the registry is built (every command):
  the calls armtree will make must bind, ``PARAMS`` must hold :class:`Param`
  objects, and a behaviour's lifecycle methods must take what py_trees passes.
  Nothing is built and no port is opened.
* :func:`deep_problems`, run by ``armtree plugins --check``: an arm's
  kinematic model is built from its defaults and checked (limits, home pose,
  link frames, link boxes, an inverse-kinematics round trip), and behaviours
  whose parameters all have defaults are constructed once.

:func:`version_problem` checks what a plugin says about the armtree versions it
supports: a module attribute ``ARMTREE_REQUIRES = ">=0.1,<0.2"`` (a PEP 440
specifier) and, for an installed distribution, its ``Requires-Dist`` on armtree.

Every problem is a :class:`Problem`: the plugin, the component and member, what
was found and what was expected, with the source file and line when known.
"""

from __future__ import annotations

import importlib.metadata
import inspect
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import py_trees
from packaging.requirements import InvalidRequirement, Requirement
from packaging.specifiers import InvalidSpecifier, SpecifierSet
from packaging.version import InvalidVersion, Version

from armtree.api.factories import COMPOSITE, DECORATOR, LEAF, construct, node_kind
from armtree.config.constructor_params import declared_params, name_argument, takes_signature_params
from armtree.config.params import Param
from armtree.config.profile_access import AnyProfile
from armtree.config.profile_sections import PROFILE_KEYS, ProfileSection
from armtree.errors import ConfigError, did_you_mean
from armtree.maths.motion.kinematics import KinematicModel

#: The module attribute in which a plugin names the armtree versions it supports.
REQUIRES_ATTRIBUTE = "ARMTREE_REQUIRES"

#: How armtree calls each kind's factory: (call shown to authors, positional argument names).
FACTORY_CALLS: dict[str, tuple[str, tuple[str, ...]]] = {
    "arm": ("factory(config, context) -> ArmDriver", ("config", "context")),
    "camera": ("factory(config, context) -> Camera", ("config", "context")),
    "tracker": ("factory(config, context) -> Tracker", ("config", "context")),
    "planner": (
        "factory(config, context, model, scene) -> Planner",
        ("config", "context", "model", "scene"),
    ),
}


@dataclass(frozen=True)
class Problem:
    """One way a component misses its interface."""

    plugin: str
    subject: str
    member: str
    found: str
    expected: str
    file: str | None = None
    line: int | None = None

    @property
    def message(self) -> str:
        """``plugin 'p': arm 'toy': member: found; expected ...; fix or skip``."""
        return (
            f"plugin {self.plugin!r}: {self.subject}: {self.member}: {self.found}; "
            f"expected {self.expected}. Fix the plugin, or skip it with -p no:{self.plugin}"
        )

    def error(self) -> ConfigError:
        """The problem as a :class:`ConfigError` at the member's source line."""
        return ConfigError(self.message, file=self.file, line=self.line)


def installed_version() -> str:
    """The installed armtree's version."""
    try:
        return importlib.metadata.version("armtree")
    except importlib.metadata.PackageNotFoundError:
        from armtree import __version__

        return __version__


# ---------------------------------------------------------------------------
# Versions
# ---------------------------------------------------------------------------


def version_problem(plugin: Any, name: str, distribution: str | None) -> ConfigError | None:
    """A clear error when ``plugin`` (or its distribution) does not support this armtree.

    Names both versions: what the plugin supports and what is installed.
    """
    installed = installed_version()
    where = f" (distribution {distribution})" if distribution else ""
    file = getattr(plugin, "__file__", None)
    declared = getattr(plugin, REQUIRES_ATTRIBUTE, None)
    sources: list[tuple[str, Any]] = []
    if declared is not None:
        sources.append((f"{REQUIRES_ATTRIBUTE} = {declared!r}", declared))
    if distribution and distribution != "armtree":
        for text in _armtree_requirements(distribution):
            sources.append((f"its requirement {text!r}", Requirement(text).specifier))
    for said, spec in sources:
        try:
            spec = spec if isinstance(spec, SpecifierSet) else SpecifierSet(str(spec))
        except InvalidSpecifier:
            return ConfigError(
                f"plugin {name!r}{where}: {said} is not a version specifier; write it as "
                f'{REQUIRES_ATTRIBUTE} = ">=0.1,<0.2" (PEP 440)',
                file=file,
            )
        try:
            ok = spec.contains(Version(installed), prereleases=True)
        except InvalidVersion:
            ok = True
        if not ok:
            return ConfigError(
                f"plugin {name!r}{where} supports armtree {spec} ({said}), but armtree "
                f"{installed} is installed: install an armtree in {spec}, a version of the "
                f"plugin made for armtree {installed}, or skip it with -p no:{name}",
                file=file,
            )
    return None


def _armtree_requirements(distribution: str) -> list[str]:
    try:
        requires = importlib.metadata.requires(distribution) or []
    except importlib.metadata.PackageNotFoundError:
        return []
    found = []
    for text in requires:
        try:
            requirement = Requirement(text)
        except InvalidRequirement:
            continue
        if requirement.name.lower() != "armtree":
            continue
        if requirement.marker is not None and not requirement.marker.evaluate({"extra": ""}):
            continue
        if str(requirement.specifier):
            found.append(text)
    return found


# ---------------------------------------------------------------------------
# Hook names (before registering)
# ---------------------------------------------------------------------------

#: The attribute ``@armtree.hookimpl`` sets on what it marks.
HOOKIMPL_ATTRIBUTE = "armtree_impl"
#: How alike a plain function's name must be to a hook's to be taken for a misspelling.
NEAR_HOOK = 0.85


def hook_name_problems(plugin: Any, name: str, hooks: Any) -> list[ConfigError]:
    """A misspelt hook in ``plugin`` (registered as ``name``), each at its ``def`` line.

    A function marked ``@armtree.hookimpl`` or named ``armtree_*`` that is no hook of
    ``hooks`` (the hook names), or an unmarked one whose name is nearly a hook's
    (``armtre_behaviours``): pluggy would ignore the last and refuse the others
    after the tree already failed on what the hook should have registered.
    """
    hooks = sorted(hooks)
    problems = []
    for attribute in dir(plugin):
        if attribute in hooks or attribute.startswith("__"):
            continue
        try:
            found = inspect.getattr_static(plugin, attribute)
        except AttributeError:
            continue
        function = getattr(found, "__func__", found)
        if not inspect.isfunction(function) or not _defined_by(plugin, function):
            continue
        marked = hasattr(function, HOOKIMPL_ATTRIBUTE)
        specname = (getattr(function, HOOKIMPL_ATTRIBUTE, None) or {}).get("specname")
        if specname in hooks:
            continue  # pluggy's way to implement a hook under another name
        # Unmarked and unprefixed, only a name that nearly is a hook's: "armtre_behaviours".
        near = attribute.startswith("arm") and did_you_mean(
            attribute, hooks, cutoff=NEAR_HOOK, list_up_to=0
        )
        if not (marked or attribute.startswith("armtree_") or near):
            continue
        hint = did_you_mean(attribute, hooks, list_up_to=0) or "; see armtree.hooks.hookspecs"
        file, line = _def_line(function)
        problems.append(
            ConfigError(
                f"plugin {name!r}: {attribute}() is not an armtree hook{hint} (the hooks: "
                f"`armtree hooks`; or skip the plugin with -p no:{name})",
                file=file,
                line=line,
            )
        )
    return sorted(problems, key=lambda e: (e.file or "", e.line or 0))


def _defined_by(plugin: Any, function: Any) -> bool:
    """True for a function the plugin defines itself (not one a module imported)."""
    if inspect.ismodule(plugin):
        return function.__module__ == plugin.__name__
    return True


def _def_line(function: Any) -> tuple[str | None, int | None]:
    """The file and the ``def`` line of ``function`` (past its decorators)."""
    try:
        file = inspect.getsourcefile(function)
        lines, first = inspect.getsourcelines(function)
    except (OSError, TypeError):
        return None, None
    for offset, text in enumerate(lines):
        if text.lstrip().startswith(("def ", "async def ")):
            return file, first + offset
    return file, first


# ---------------------------------------------------------------------------
# Interfaces (at load)
# ---------------------------------------------------------------------------


def interface_problems(component: Any) -> list[Problem]:
    """Every way ``component`` (a registry entry) misses what armtree will call on it."""
    kind, name, factory = component.kind, component.name, component.factory
    report = _Reporter(component.plugin, f"{kind} {name!r}")
    if kind == "command":
        _check_command(factory, report)
        return report.problems
    if kind == "predicate":
        _check_predicate(factory, report)
        return report.problems
    if kind == "profile_section":
        _check_profile_section(name, factory, report)
        return report.problems
    if not callable(factory):
        report.add(factory, "factory", f"{type(factory).__name__} {factory!r}", "a callable")
        return report.problems
    params_ok = _check_params(factory, report)
    if kind == "behaviour":
        _check_behaviour(factory, report, params_ok)
    else:
        call, args = FACTORY_CALLS[kind]
        report.binds(factory, "factory", args, {}, call)
        if kind == "arm":
            for member, call_args, call in (
                ("model", ("config",), "factory.model(config) -> KinematicModel"),
                ("emulator", ("config", "clock"), "factory.emulator(config, clock) -> PtyEmulator"),
                ("grips_with", ("config",), "factory.grips_with(config) -> 'suction' | 'gripper'"),
                ("simulated", ("config",), "factory.simulated(config) -> bool"),
            ):
                helper = getattr(factory, member, None)
                if helper is None:
                    continue
                if not callable(helper):
                    report.add(factory, f"factory.{member}", f"{type(helper).__name__}", call)
                else:
                    report.binds(helper, f"factory.{member}", call_args, {}, call)
    return report.problems


class _Reporter:
    """Collects problems of one component."""

    def __init__(self, plugin: str, subject: str) -> None:
        self.plugin, self.subject = plugin, subject
        self.problems: list[Problem] = []

    def add(self, obj: Any, member: str, found: str, expected: str) -> None:
        file, line = _source(obj)
        if line is not None and not member.split("[")[0].endswith(")"):
            line = _assignment_line(obj, member.split("[")[0].strip()) or line
        self.problems.append(
            Problem(self.plugin, self.subject, member, found, expected, file, line)
        )

    def binds(
        self, function: Any, member: str, args: tuple[Any, ...], kwargs: dict[str, Any], call: str
    ) -> bool:
        """Record a problem unless ``function(*args, **kwargs)`` binds to its signature."""
        try:
            signature = inspect.signature(function)
        except (TypeError, ValueError):
            return True  # a builtin or C callable: nothing to read
        try:
            signature.bind(*args, **kwargs)
        except TypeError as exc:
            self.add(function, member, f"signature {_name(function)}{signature} ({exc})", call)
            return False
        return True


def _check_params(factory: Any, report: _Reporter) -> bool:
    """True when ``PARAMS`` is absent or a sequence of distinct :class:`Param`."""
    if "PARAMS" not in dir(factory):
        return True
    params = factory.PARAMS
    expected = "a tuple of armtree.Param(name, type, default, unit=, doc=)"
    if not isinstance(params, (tuple, list)):
        report.add(factory, "PARAMS", f"a {type(params).__name__}", expected)
        return False
    before = len(report.problems)
    seen: set[str] = set()
    for i, param in enumerate(params):
        if not isinstance(param, Param):
            report.add(factory, f"PARAMS[{i}]", f"{type(param).__name__} {param!r}", expected)
        elif param.name in seen:
            report.add(
                factory, f"PARAMS[{i}]", f"a second parameter {param.name!r}", "unique names"
            )
        else:
            seen.add(param.name)
    return len(report.problems) == before


#: Lifecycle methods py_trees and the runtime call, with the arguments they pass.
LIFECYCLE: tuple[tuple[str, tuple[Any, ...], dict[str, Any], str], ...] = (
    ("setup", (), {"rig": None, "clock": None, "runtime": None}, "setup(self, **kwargs)"),
    ("initialise", (), {}, "initialise(self)"),
    ("update", (), {}, "update(self) -> py_trees.common.Status"),
    ("terminate", (py_trees.common.Status.INVALID,), {}, "terminate(self, new_status)"),
    ("halting", (), {}, "halting(self) -> bool"),
)


def _check_behaviour(factory: Any, report: _Reporter, params_ok: bool) -> None:
    if not isinstance(factory, type):
        return  # an adapter (NodeType) or a function: only what it builds can tell
    if not issubclass(factory, py_trees.behaviour.Behaviour):
        bases = ", ".join(b.__name__ for b in factory.__mro__[1:-1]) or "object"
        report.add(
            factory,
            "class",
            f"{factory.__name__} derives from {bases}",
            "a subclass of py_trees.behaviour.Behaviour (or armtree.Behaviour)",
        )
        return
    abstract = sorted(getattr(factory, "__abstractmethods__", ()) or ())
    if abstract:
        report.add(
            factory,
            "class",
            f"{factory.__name__} leaves {', '.join(m + '()' for m in abstract)} undefined",
            "a behaviour that defines "
            + ", ".join(f"{m}()" for m in abstract)
            + " (py_trees cannot build it otherwise)",
        )
    for method, args, kwargs, call in LIFECYCLE:
        function = getattr(factory, method, None)
        if function is None:
            continue
        if not callable(function):
            report.add(factory, method, f"{type(function).__name__}, not a method", call)
            continue
        report.binds(function, f"{method}()", (None, *args), kwargs, call)
    if not params_ok:
        return
    params = {p.name: p.default for p in declared_params(factory)}
    kind = node_kind(factory)
    if kind == COMPOSITE:
        params["children"] = []
    elif kind == DECORATOR:
        params["child"] = None
    if takes_signature_params(factory):
        _check_signature_constructor(factory, report)
        if name_argument(factory) == "keyword":
            params["name"] = "node"
            report.binds(factory.__init__, "__init__", (None,), params, "keyword parameters")
        return
    report.binds(
        factory.__init__,
        "__init__",
        (None, "node"),
        params,
        "__init__(self, name, **params) taking every parameter of PARAMS by keyword",
    )


def _check_signature_constructor(factory: type[object], report: _Reporter) -> None:
    signature = inspect.signature(factory.__init__)
    for index, (pname, parameter) in enumerate(signature.parameters.items()):
        if parameter.kind is inspect.Parameter.POSITIONAL_ONLY and index > 1:
            report.add(
                factory.__init__,
                f"__init__ parameter {pname!r}",
                "positional-only",
                "parameters a tree can give by keyword (the loader passes them as name=value)",
            )


def _check_methods(
    component: Any, report: _Reporter, methods: tuple[tuple[str, tuple[str, ...], str], ...]
) -> None:
    """An object (or a class built with no arguments) whose ``methods`` take those arguments."""
    if isinstance(component, type):
        try:
            inspect.signature(component).bind()
        except (TypeError, ValueError) as exc:
            report.add(
                component,
                "class",
                f"{component.__name__}() fails: {exc}",
                "a class built with no arguments",
            )
            return
    for member, args, call in methods:
        function = getattr(component, member, None)
        if not callable(function):
            report.add(component, member, "missing" if function is None else "not callable", call)
            continue
        bound_args = (None, *args) if isinstance(component, type) else args
        report.binds(function, f"{member}()", bound_args, {}, call)


def _check_command(command: Any, report: _Reporter) -> None:
    _check_methods(
        command,
        report,
        (
            (
                "configure",
                ("parser",),
                "configure(parser) adding its arguments to an argparse parser",
            ),
            ("run", ("args",), "run(args) -> int exit code"),
        ),
    )
    if not isinstance(getattr(command, "help", ""), str):
        report.add(command, "help", f"{type(command.help).__name__}", "a one-line str")


def _check_predicate(predicate: Any, report: _Reporter) -> None:
    _check_methods(
        predicate,
        report,
        (
            ("check", ("entry", "world"), "check(entry, world) -> [(key, message)]"),
            ("judge", ("entry", "obj", "world"), "judge(entry, obj, world) -> Judgement"),
            ("describe", ("entry",), "describe(entry) -> str"),
        ),
    )
    if getattr(predicate, "SUBJECT", "required") not in ("required", "optional", "none"):
        report.add(
            predicate, "SUBJECT", repr(predicate.SUBJECT), "'required', 'optional' or 'none'"
        )


def _check_profile_section(name: str, section: Any, report: _Reporter) -> None:
    if name in PROFILE_KEYS:
        report.add(section, "name", f"armtree's own section {name!r}", "a name of the plugin's own")
    if not isinstance(section, ProfileSection):
        report.add(section, "section", f"{type(section).__name__} {section!r}", "a ProfileSection")
        return
    if not isinstance(section.schema, dict):
        report.add(section, "schema", type(section.schema).__name__, "a JSON Schema mapping")
    if section.check is not None:
        call = "check(profile) -> [ConfigError]"
        if not callable(section.check):
            report.add(section, "check", type(section.check).__name__, call)
        else:
            report.binds(section.check, "check", ("profile",), {}, call)


# ---------------------------------------------------------------------------
# Deep checks (armtree plugins --check)
# ---------------------------------------------------------------------------


def deep_problems(component: Any, notes: list[str] | None = None) -> list[Problem]:
    """Checks that build things: an arm's kinematic model, behaviours with defaults only.

    What could not be checked (a model that needs configuration beyond its
    defaults) is appended to ``notes``.
    """
    report = _Reporter(component.plugin, f"{component.kind} {component.name!r}")
    if component.kind == "arm" and callable(getattr(component.factory, "model", None)):
        _check_model(component, report, notes if notes is not None else [])
    elif component.kind == "behaviour":
        _check_construction(component, report)
    return report.problems


def _defaults(component: Any) -> dict[str, Any]:
    return {p.name: p.default for p in component.params if not p.required}


def _check_construction(component: Any, report: _Reporter) -> None:

    factory = component.factory
    if node_kind(factory) != LEAF or any(p.required for p in component.params):
        return
    try:
        behaviour = construct(factory, component.name, _defaults(component))
    except (ValueError, ConfigError):
        return  # it wants parameters its defaults leave out: a tree gives them
    except Exception as exc:  # noqa: BLE001 - reported as the plugin's problem
        report.add(
            factory,
            "constructor",
            f"raised {type(exc).__name__}: {exc}",
            "to build with its defaults",
        )
        return
    if not isinstance(behaviour, py_trees.behaviour.Behaviour):
        report.add(
            factory, "constructor", f"built a {type(behaviour).__name__}", "a py_trees behaviour"
        )


def _check_model(component: Any, report: _Reporter, notes: list[str]) -> None:
    make = component.factory.model
    config = {"type": component.name, **_defaults(component)}
    try:
        model = make(config)
    except ConfigError as exc:
        notes.append(f"{report.subject}: model not checked, it needs configuration: {exc.message}")
        return
    except Exception as exc:  # noqa: BLE001 - reported as the plugin's problem
        report.add(
            make,
            "factory.model(defaults)",
            f"raised {type(exc).__name__}: {exc}",
            "a KinematicModel",
        )
        return
    if not isinstance(model, KinematicModel):
        report.add(
            make,
            "factory.model(defaults)",
            f"a {type(model).__name__}",
            "an armtree.maths.motion.kinematics.KinematicModel",
        )
        return
    for member, found, expected in model_problems(model):
        report.add(model_member(model, member), member, found, expected)


def model_member(model: Any, member: str) -> Any:
    """What a problem's ``member`` names in the model's code, for its file and line: the
    method (``ik_all(...)``, ``workspace_shape()``), else the constructor that sets the
    attribute (``home``, ``joints[...]``, ``boxes[...]``)."""
    name = member.split("(")[0].split("[")[0].strip()
    found = getattr(type(model), name, None)
    if callable(found) and not isinstance(found, type):
        return found
    return type(model).__init__ if "__init__" in vars(type(model)) else type(model)


def rig_problems(profile: AnyProfile) -> list[ConfigError]:
    """``armtree plugins --check``'s checks on the arm ``profile`` names, its kinematic
    model built from the profile's own ``arm:`` section (limits, home, link frames and
    boxes, the inverse kinematics' round trip, the workspace it describes).

    Each error is at the plugin's source line, and names the profile's ``arm.type``
    line; nothing is reported for an arm the profile's own checks already refuse.
    """
    manager = getattr(profile, "manager", None)
    config = profile.component("arm") if hasattr(profile, "component") else None
    if manager is None or not config or not isinstance(config.get("type"), str):
        return []
    registry = manager.registry
    if not registry.has("arm", config["type"]):
        return []
    component = registry.get("arm", config["type"])
    make = getattr(component.factory, "model", None)
    if not callable(make):
        return []
    report = _Reporter(component.plugin, f"arm {component.name!r}")
    try:
        model = make(dict(config))
    except (ConfigError, ValueError, TypeError, KeyError):
        return []  # the profile's checks say what is wrong with its arm: section
    except Exception as exc:  # noqa: BLE001 - reported as the plugin's problem
        report.add(make, "factory.model(config)", f"raised {type(exc).__name__}: {exc}", "a model")
        model = None
    from armtree.maths.motion.kinematics import KinematicModel

    if isinstance(model, KinematicModel):
        for member, found, expected in model_problems(model):
            report.add(model_member(model, member), member, found, expected)
    mark = profile.mark("arm.type") if hasattr(profile, "mark") else None
    built = f" (the model built from the profile's arm: at {mark})" if mark else ""
    return [
        ConfigError(
            problem.message.replace(". Fix the plugin,", f"{built}. Fix the plugin,", 1),
            file=problem.file,
            line=problem.line,
        )
        for problem in report.problems
    ]


def model_problems(model: Any, tol: float = 1e-3) -> list[tuple[str, str, str]]:
    """``(member, found, expected)`` for every inconsistency of a kinematic model.

    Joints with ``lower < upper``, a home pose of the right length inside the
    limits, finite link frames, link boxes on existing frames with positive
    sizes, ``ik_all(position(home))`` containing home within ``tol``
    (degrees / mm), and, for a model that describes its workspace
    (``workspace_shape()``), finite bounds and the tool positions of home and of
    configurations within the limits inside it, so planners, the workspace tool
    and the simulation work.
    """
    out: list[tuple[str, str, str]] = []
    n = len(model.joints)
    if n == 0:
        return [("joints", "no joints", "a tuple of armtree.maths.motion.kinematics.Joint")]
    for joint in model.joints:
        if not joint.lower < joint.upper:
            out.append(
                (f"joints[{joint.name}]", f"limits [{joint.lower}, {joint.upper}]", "lower < upper")
            )
        if joint.kind not in ("revolute", "prismatic"):
            out.append((f"joints[{joint.name}]", f"kind {joint.kind!r}", "revolute or prismatic"))
    home = np.asarray(model.home, dtype=float)
    if home.shape != (n,):
        return [*out, ("home", f"shape {home.shape}", f"({n},), one value per joint")]
    if not bool(model.within_limits(home)):
        out.append(
            (
                "home",
                f"{home.tolist()} outside the limits or constraints",
                "a pose the arm can take",
            )
        )
    frames = _call(out, "link_frames(home)", lambda: np.asarray(model.link_frames(home)))
    if frames is None:
        return out
    if frames.ndim != 3 or frames.shape[1:] != (4, 4) or not np.all(np.isfinite(frames)):
        return [*out, ("link_frames(home)", f"shape {frames.shape}", "(L, 4, 4) finite poses")]
    for i, box in enumerate(model.boxes):
        if not 0 <= box.link < len(frames):
            out.append(
                (f"boxes[{i}] {box.name}", f"link {box.link}", f"a frame index below {len(frames)}")
            )
        if min(box.size) <= 0:
            out.append((f"boxes[{i}] {box.name}", f"size {box.size}", "positive sizes (mm)"))
    for a, b in model.self_collision_pairs:
        if not (0 <= a < len(model.boxes) and 0 <= b < len(model.boxes)):
            out.append(
                ("self_collision_pairs", f"({a}, {b})", f"box indices below {len(model.boxes)}")
            )
    position = _call(out, "position(home)", lambda: np.asarray(model.position(home), dtype=float))
    if position is None or position.shape != (3,) or not np.all(np.isfinite(position)):
        return out
    out.extend(_workspace_problems(model, home, tol))
    miss = _round_trip_miss(out, model, home, position, tol)
    if miss == "no solution":
        out.append(("ik_all(position(home))", "no solution", "the home pose among the solutions"))
    elif miss is not None:
        out.append(("ik_all(position(home))", miss, "fk(ik(p)) == p"))
    elif not out:
        out.extend(_sampled_round_trip(model, home, tol))
    return out


def _round_trip_miss(
    out: list[tuple[str, str, str]],
    model: Any,
    q: np.ndarray,
    position: np.ndarray,
    tol: float,
    member: str = "ik_all(position(home))",
) -> str | None:
    """What ``ik_all(position)`` gets wrong for the tool position of joints ``q``, or None.

    Joints the position does not fix (a wrist's yaw) may come back anything, so the
    tools the solutions reach are compared, not the joints.
    """
    solutions = _call(out, member, lambda: np.asarray(model.ik_all(position), dtype=float))
    if solutions is None:
        return None
    solutions = solutions.reshape(-1, len(q))
    solutions = solutions[np.all(np.isfinite(solutions), axis=-1)]
    if not len(solutions):
        return "no solution"
    reached = np.asarray(model.position(solutions), dtype=float)
    if np.min(np.linalg.norm(reached - position, axis=-1)) > tol:
        return (
            f"solutions reaching {np.round(reached[0], 3).tolist()} mm, "
            f"not {np.round(position, 3).tolist()}"
        )
    return None


#: Configurations within the limits whose tool positions the inverse kinematics must reach.
IK_SAMPLES = 24


def _sampled_round_trip(model: Any, home: np.ndarray, tol: float) -> list[tuple[str, str, str]]:
    """The IK round trip away from home, where a mirrored axis or a swapped elbow shows.

    Home often lies on a symmetry (``y = 0``) that hides a sign error. A solver that
    finds no solution for a pose is not faulted (many keep the tool pointing down, so
    most random poses are not theirs to reach); one that answers with a wrong pose is.
    """
    rng = np.random.default_rng(1)  # the same configurations every time
    lo, hi = model.lower, model.upper
    samples = lo + (hi - lo) * rng.random((IK_SAMPLES, len(home)))
    samples = samples[np.asarray(model.within_limits(samples), dtype=bool)]
    out: list[tuple[str, str, str]] = []
    for q in samples:
        position = np.asarray(model.position(q), dtype=float)
        miss = _round_trip_miss(out, model, q, position, tol, "ik_all(position(q))")
        if out:
            return out
        if miss is not None and miss != "no solution":
            joints = np.round(q, 2).tolist()
            return [("ik_all(position(q))", f"{miss} (joints {joints})", "fk(ik(p)) == p")]
    return []


#: Configurations within the limits whose tool positions must lie in the described workspace.
WORKSPACE_SAMPLES = 64


def _workspace_problems(model: Any, home: np.ndarray, tol: float) -> list[tuple[str, str, str]]:
    """The workspace a model describes against where its forward kinematics puts the tool."""
    from armtree.maths.motion.workspace import ArmWorkspace

    out: list[tuple[str, str, str]] = []
    workspace = _call(out, "workspace_shape()", lambda: ArmWorkspace(model))
    if workspace is None or workspace.kind != "model" or workspace.bounds is None:
        return out
    lower, upper = workspace.bounds
    if lower.shape != (3,) or upper.shape != (3,) or not np.all(lower < upper):
        return [("workspace_shape()", f"bounds {lower} to {upper}", "finite lower < upper (mm)")]
    rng = np.random.default_rng(0)  # the same configurations every time
    lo, hi = model.lower, model.upper
    samples = np.vstack([home, lo + (hi - lo) * rng.random((WORKSPACE_SAMPLES, len(home)))])
    samples = samples[np.asarray(model.within_limits(samples), dtype=bool)]
    reached = _call(out, "position(q)", lambda: np.asarray(model.position(samples), dtype=float))
    if reached is None or not len(samples):
        return out
    inside = _call(out, "workspace_shape()", lambda: workspace.reachable(reached, tol=tol))
    if inside is None:
        return out
    outside = np.flatnonzero(~np.asarray(inside, dtype=bool))
    if len(outside):
        q, p = samples[outside[0]], reached[outside[0]]
        out.append(
            (
                "workspace_shape()",
                f"the tool at {np.round(p, 2).tolist()} mm (joints {np.round(q, 2).tolist()}, "
                f"within the limits) outside it, {len(outside)} of {len(samples)} such",
                "every position the arm reaches inside its workspace",
            )
        )
    return out


def _call(out: list[tuple[str, str, str]], member: str, function: Callable[[], Any]) -> Any:
    try:
        return function()
    except Exception as exc:  # noqa: BLE001 - reported as the plugin's problem
        out.append((member, f"raised {type(exc).__name__}: {exc}", "to work on the home pose"))
        return None


def _source(obj: Any) -> tuple[str | None, int | None]:
    target = inspect.unwrap(obj) if callable(obj) else obj
    if not (inspect.isclass(target) or inspect.isroutine(target)):
        target = type(target)
    try:
        file = inspect.getsourcefile(target)
        line = inspect.getsourcelines(target)[1]
    except (TypeError, OSError):
        return None, None
    return file, line


def _assignment_line(function: Any, attribute: str) -> int | None:
    """The line of ``function`` (a constructor) that sets ``self.<attribute>``, if one does."""
    try:
        lines, first = inspect.getsourcelines(inspect.unwrap(function))
    except (OSError, TypeError):
        return None
    pattern = re.compile(rf"\bself\.{re.escape(attribute)}\s*(:[^=]*)?=[^=]")
    for offset, text in enumerate(lines):
        if pattern.search(text):
            return first + offset
    return None


def _name(function: Any) -> str:
    return getattr(function, "__qualname__", None) or type(function).__name__


__all__ = [
    "HOOKIMPL_ATTRIBUTE",
    "Problem",
    "REQUIRES_ATTRIBUTE",
    "installed_version",
    "deep_problems",
    "hook_name_problems",
    "interface_problems",
    "model_member",
    "model_problems",
    "rig_problems",
    "version_problem",
]
