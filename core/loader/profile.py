"""Hardware profiles: which arm, camera, tracker and planner a tree runs on.

:func:`load_profile` finds a profile by path or name (working directory, then
the shipped ``hardware/``), applies ``--set KEY=VALUE`` overrides and validates
the whole file before returning, collecting every problem into one
:class:`armtree.ConfigError` whose ``errors`` carry file, line and column:

* known top-level sections only (did-you-mean); ``arm`` is required;
* ``arm``/``camera``/``tracker``/``planner``: a mapping with a ``type`` that a
  plugin registered (did-you-mean); when the factory declares ``PARAMS`` the
  other keys are checked against them (unknown keys, types, required ones);
* ``tags``: ``role: {id: N | ids: [N, ...], size_mm: > 0, family_ids: {FAMILY: N | [N, ...]}}``,
  no id used twice (the trackers plugin checks the ids against their families);
* ``places``: ``name: [x, y, z]`` in mm; ``obstacles``: a list of shapes
  (``box: {center, size}`` in mm, ``cylinder``, ``sphere``, ``mesh: {file}``);
  ``table: {z: MM}`` (or ``table: MM``): the table top in the arm's base frame;
* ``workcell``: the task geometry skills use (:mod:`armtree.config.workcell`);
* then the planning scene these make (:meth:`armtree.maths.motion.scene.Scene.from_profile`):
  meshes that fail to load, places inside an obstacle or under the table;
* ``plugins`` is a list of modules or ``.py`` files loaded before validation;
  ``watchdog: {tick_s: S, stall_s: S}``: the longest a tick may take (wall
  seconds, default 120) before the run ends with exit 3, and how long a run may
  make no progress (run seconds, default 60) before it is reported as a stall;
* sections plugins register (``armtree_profile_sections``, such as the built-in
  simulation's ``world:``): their value's type, then each section's own check;
* last, every plugin's ``armtree_validate_profile`` hook, its errors reported
  with the others.

Overrides use dotted keys and YAML-typed values: ``arm.type=vicra``,
``camera.width=800``, ``places.home=[200, 0, 80]``.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from armtree.api.rig import TagSpec
from armtree.config.params import check_value
from armtree.config.profile_access import AnyProfile, component_config
from armtree.config.profile_include import apply_includes
from armtree.config.profile_sections import COMPONENT_SECTIONS, PROFILE_KEYS
from armtree.config.profile_spec import check_sections
from armtree.config.resolve import available, not_a_file, resolve
from armtree.config.spec import Context
from armtree.config.yamlio import MarkedDict, MarkedList, error_at, load_yaml, load_yaml_file, plain
from armtree.errors import ConfigError, Mark, did_you_mean, shown
from armtree.hooks.hook_calls import call_isolated, plugin_of
from armtree.hooks.plugin_checks import rig_problems
from armtree.hooks.plugin_manager import PluginManager, Registry, get_plugin_manager
from armtree.maths.motion.scene import Scene

#: Sections a profile must have.
REQUIRED_SECTIONS = ("arm",)
#: Keys that name the profile rather than configure it (``--set`` cannot address them).
_NOT_OVERRIDABLE = frozenset({"profile", "description"})
#: Sections the planning scene is built from (checked together at load time).
SCENE_SECTIONS = frozenset({"table", "obstacles", "places"})


def registered_sections(manager: PluginManager | None) -> dict[str, Any]:
    """``{name: Component}`` of the profile sections plugins registered (none when the
    registry cannot be built: that error is reported where the registry is needed)."""
    manager = manager or get_plugin_manager()
    try:
        registry = manager.registry
    except ConfigError:
        return {}
    return {
        name: registry.get("profile_section", name) for name in registry.names("profile_section")
    }


def section_names(manager: PluginManager | None) -> tuple[str, ...]:
    """Every top-level key a profile may have: armtree's own and the plugins'."""
    return (*PROFILE_KEYS, *(k for k in registered_sections(manager) if k not in PROFILE_KEYS))


def override_sections(manager: PluginManager | None) -> frozenset[str]:
    """Sections a ``--set`` key may start with to address the profile rather than the blackboard."""
    return frozenset(section_names(manager)) - _NOT_OVERRIDABLE


@dataclass(frozen=True)
class Override:
    """One ``--set KEY=VALUE``: the dotted key split into parts and the YAML-typed value."""

    keys: tuple[str, ...]
    value: Any
    text: str

    @property
    def mark(self) -> Mark:
        """A position naming the override itself, for error messages."""
        return Mark(f"--set {self.text}", 1, len(".".join(self.keys)) + 2)


def parse_override(text: str) -> Override:
    """Parse ``KEY=VALUE`` (dotted key, YAML value); raise :class:`ConfigError` if malformed."""
    key, sep, raw = text.partition("=")
    key = key.strip()
    parts = tuple(key.split("."))
    if not sep or not key or any(not p.strip() for p in parts):
        raise ConfigError(
            f"expected KEY=VALUE with a dotted KEY (e.g. arm.type=vicra), got {shown(text)}",
            file="--set",
        )
    try:
        value = plain(load_yaml(raw, "--set")) if raw.strip() else ""
    except ConfigError as exc:
        where = f" (character {exc.column} of the value)" if exc.column else ""
        raise ConfigError(
            f"value of {key} is not valid YAML: {exc.message}{where}", file="--set"
        ) from None
    return Override(tuple(p.strip() for p in parts), value, text)


def parse_overrides(texts: Iterable[str]) -> tuple[list[Override], list[ConfigError]]:
    """Parse every override, collecting errors instead of stopping at the first."""
    done: list[Override] = []
    errors: list[ConfigError] = []
    for text in texts:
        try:
            done.append(parse_override(text))
        except ConfigError as exc:
            errors.append(exc)
    return done, errors


def apply_override(data: MarkedDict, override: Override) -> None:
    """Set ``override`` in ``data`` (creating mappings on the way), marking where it came from."""
    node = data
    mark = override.mark
    for depth, part in enumerate(override.keys[:-1]):
        child = node.get(part)
        if child is None:
            child = MarkedDict(mark=mark)
            node[part] = child
            node.key_marks[part] = node.value_marks[part] = mark
        elif not isinstance(child, dict):
            path = ".".join(override.keys[: depth + 1])
            raise error_at(f"cannot set {'.'.join(override.keys)}: {path} is not a mapping", mark)
        if not isinstance(child, MarkedDict):
            child = MarkedDict(child, mark=mark)
            node[part] = child
        node = child
    last = override.keys[-1]
    if (
        len(override.keys) == 2
        and override.keys[0] in COMPONENT_SECTIONS
        and last == "type"
        and node.get("type") != override.value
    ):
        # Swapping hardware with one key (--set arm.type=vicra): the keys the file
        # wrote for the previous type may mean nothing to the new one.
        node.swapped_from = node.get("type")
    node[last] = _marked_copy(override.value, mark)
    node.key_marks[last] = node.value_marks[last] = mark


def _marked_copy(value: Any, mark: Mark) -> Any:
    if isinstance(value, dict):
        out = MarkedDict(mark=mark)
        for k, v in value.items():
            out[k] = _marked_copy(v, mark)
            out.key_marks[k] = out.value_marks[k] = mark
        return out
    if isinstance(value, list):
        items = MarkedList([_marked_copy(v, mark) for v in value], mark=mark)
        items.item_marks = [mark] * len(items)
        return items
    return value


@dataclass(frozen=True)
class Swap:
    """A component whose ``type`` a ``--set`` changed: the type the file was written
    for and the keys dropped because the new type does not take them (value, where)."""

    previous: str
    dropped: dict[str, tuple[Any, Mark | None]] = field(default_factory=dict)


@dataclass
class Profile:
    """A validated hardware profile.

    ``data`` is the file's content after overrides (plain mappings and lists);
    ``marks`` maps dotted paths (``"arm.port"``, ``"tags.ducky.id"``) to where
    each value was written, so a component can report a bad value precisely
    with :meth:`error`. Lengths are mm. ``invalid`` names the top-level
    sections that failed armtree's own checks; it is only non-empty while the
    ``armtree_validate_profile`` hooks run (a loaded profile has none).
    ``swaps`` names the components whose type an override changed
    (``--set arm.type=vicra``), so plugins can check that the rest of the file
    fits the new one.
    """

    name: str
    source: Path | None
    data: dict[str, Any]
    marks: dict[str, Mark] = field(default_factory=dict)
    plugins: list[str] = field(default_factory=list)
    manager: PluginManager | None = None
    invalid: frozenset[str] = frozenset()
    swaps: dict[str, Swap] = field(default_factory=dict)

    @property
    def registry(self) -> Registry:
        """The components of the plugins it was loaded with (the process's, without)."""
        return (self.manager or get_plugin_manager()).registry

    @property
    def description(self) -> str:
        """The profile's one-line description."""
        return str(self.data.get("description") or "")

    def mark(self, path: str) -> Mark | None:
        """Where the value at dotted ``path`` (or its nearest written parent) came from."""
        while path:
            if path in self.marks:
                return self.marks[path]
            path = path.rpartition(".")[0]
        return self.marks.get("")

    def error(self, path: str, message: str) -> ConfigError:
        """A :class:`ConfigError` about the value at dotted ``path``, at its position."""
        return error_at(f"{path}: {message}", self.mark(path), str(self.source or self.name))

    def section(self, name: str) -> dict[str, Any] | None:
        """A top-level section as given, or ``None``."""
        value = self.data.get(name)
        return value if isinstance(value, dict) else None

    def component(self, section: str) -> dict[str, Any] | None:
        """The ``arm``/``camera``/``tracker``/``planner`` config with declared defaults filled in.

        ``None`` when the profile has no such section.
        """
        config = self.section(section)
        if config is None:
            return None
        out = dict(config)
        registry = self.registry
        kind = COMPONENT_SECTIONS[section]
        if registry.has(kind, out.get("type", "")):
            for param in registry.get(kind, out["type"]).params:
                if param.name in out and out[param.name] is None and param.default is None:
                    continue
                if param.name in out:
                    out[param.name] = check_value(param, out[param.name])
                elif not param.required:
                    out[param.name] = param.default
        return out

    def tags(self) -> dict[str, TagSpec]:
        """Marker roles by name."""
        out: dict[str, TagSpec] = {}
        for role, spec in (self.section("tags") or {}).items():
            out[str(role)] = tag_spec(str(role), spec)
        return out

    def places(self) -> dict[str, list[float]]:
        """Named places, ``[x, y, z]`` in mm in the arm's base frame."""
        return {
            str(k): [float(v) for v in xyz] for k, xyz in (self.section("places") or {}).items()
        }

    def obstacles(self) -> list[dict[str, Any]]:
        """The obstacle shapes as given (mm)."""
        return list(self.data.get("obstacles") or [])

    def with_overrides(
        self, overrides: Iterable[str | Override], manager: PluginManager | None = None
    ) -> Profile:
        """A new, re-validated profile with ``overrides`` applied."""
        data = copy.deepcopy(self.data)
        marked = _remark(data, self.marks, "")
        marked._included = True  # the includes are in already; --set include= adds more
        return _finish(marked, self.source, list(overrides), manager or self.manager, None)


def load_profile(
    path_or_name: str | Path,
    overrides: Iterable[str | Override] = (),
    *,
    manager: PluginManager | None = None,
    base: Path | None = None,
    where: Mark | None = None,
) -> Profile:
    """Find, read, override and validate a hardware profile.

    ``path_or_name`` is a path or a name looked up in the working directory,
    then ``base`` (the directory of a tree naming the profile), then the shipped
    ``hardware/``; ``.yaml`` may be left out. ``overrides`` are ``KEY=VALUE``
    strings or parsed :class:`Override` objects. ``where`` is the position of the reference
    (a tree's ``rig:``) for the not-found error. Raises :class:`ConfigError` listing every problem.
    """
    path = resolve(path_or_name, "profile", base)
    if path is None:
        shipped = available("profile")
        raise error_at(
            f"no hardware profile {shown(str(path_or_name))} in the working directory"
            f"{' or next to the tree' if base else ''} or among the shipped profiles"
            f"{not_a_file(path_or_name, 'profile', base)}"
            f"{did_you_mean(Path(str(path_or_name)).stem, shipped)}",
            where,
            str(path_or_name),
        )
    data = load_yaml_file(path)
    return _finish(data, path, list(overrides), manager, path.stem)


def _finish(
    data: Any,
    source: Path | None,
    overrides: list[str | Override],
    manager: PluginManager | None,
    default_name: str | None,
) -> Profile:
    file = str(source) if source else "<profile>"
    errors: list[ConfigError] = []
    if data is None:
        data = MarkedDict(mark=Mark(file, 1, 1))
    if not isinstance(data, MarkedDict):
        raise error_at(
            "a profile must be a mapping of sections",
            getattr(data, "mark", None) or Mark(file, 1, 1),
            file,
        )
    parsed: list[Override] = []
    for item in overrides:
        try:
            parsed.append(parse_override(item) if isinstance(item, str) else item)
        except ConfigError as exc:
            errors.append(exc)
    # --set include=FILE first, then the included files, then every other --set
    includes = [o for o in parsed if o.keys[0] == "include"]
    for override in includes:
        try:
            apply_override(data, override)
        except ConfigError as exc:
            errors.append(exc)
    if includes or not getattr(data, "_included", False):
        apply_includes(data, source, errors)
    for override in parsed:
        if override.keys[0] == "include":
            continue
        try:
            apply_override(data, override)
        except ConfigError as exc:
            errors.append(exc)
    manager = manager or get_plugin_manager()
    plugins = _plugins(data, source, errors)
    if plugins:
        try:
            # A spec with no known place is one the manager reports without a position.
            where = {spec: mark for spec, mark in plugins if mark is not None}
            manager = manager.extended([p for p, _ in plugins], where)
        except ConfigError as exc:
            errors.append(exc)
    invalid = _validate(data, manager, errors)
    name = data.get("profile") or default_name or "profile"
    profile = Profile(
        name=str(name),
        source=source,
        data=plain(data),
        marks=_flatten_marks(data),
        plugins=[p for p, _ in plugins],
        manager=manager,
        invalid=frozenset(invalid),
        swaps={
            section: Swap(node.swapped_from, dict(getattr(node, "dropped", {})))
            for section in COMPONENT_SECTIONS
            if isinstance(node := data.get(section), MarkedDict)
            and getattr(node, "swapped_from", None)
        },
    )
    if "arm" not in invalid:
        # The arm's model as plugins --check checks it, built from this profile: a home
        # outside the limits or an IK with a sign error is the plugin's, reported first.
        errors[:0] = rig_problems(profile)
    if not invalid & SCENE_SECTIONS:
        errors.extend(_check_scene(profile))
    errors.extend(_component_checks(profile, manager))
    errors.extend(place_error(profile, e) for e in _section_checks(profile, manager, not errors))
    errors.extend(place_error(profile, e) for e in _plugin_checks(profile, manager, not errors))
    if errors:
        order = {file: i for i, file in enumerate(dict.fromkeys(e.file for e in errors))}
        errors.sort(key=lambda e: (order[e.file], e.line or 0, e.column or 0))
        raise ConfigError(
            errors[0].message, errors[0].file, errors[0].line, errors[0].column, errors
        )
    profile.invalid = frozenset()
    return profile


def _check_scene(profile: Profile) -> list[ConfigError]:
    """The planning scene's own load-time errors (mesh files, places inside obstacles)."""
    try:
        Scene.from_profile(profile)
    except ConfigError as exc:
        return list(exc.errors)
    return []


#: A message that starts with the dotted path of the value it is about (``camera.fps: ...``,
#: ``arm.servos[2].channel must ...``).
_PATH_PREFIX = re.compile(r"^((?:[A-Za-z_]\w*)(?:\.[A-Za-z_]\w*|\[\d+\]|\.\d+)*)(?=[:\s])")


def place_error(profile: Profile, error: ConfigError) -> ConfigError:
    """``error`` at the file, line and column of the value its message names.

    A component's own checks (and the rig builder's) know the profile path of a
    bad value but not its position: ``"camera.fps: must be positive"`` becomes
    ``sim_dobot.yaml:17:8: camera.fps: must be positive``. An error that already
    has a line, or whose message names no profile section, is returned as it is.
    """
    if error.line is not None or len(error.errors) > 1:
        return error
    found = _PATH_PREFIX.match(error.message)
    known = section_names(profile.manager)
    if found is None or found.group(1).split(".")[0].split("[")[0] not in known:
        return error
    path = re.sub(r"\[(\d+)\]", r".\1", found.group(1))
    return error_at(error.message, profile.mark(path), str(profile.source or profile.name))


def _component_checks(profile: Profile, manager: PluginManager) -> list[ConfigError]:
    """Each component's own checks, run at load time without opening a device.

    A factory may offer ``validate(config, profile)`` (raising :class:`ConfigError`);
    an arm's ``model(config)`` builds its kinematic model from the profile, which
    checks its geometry. Errors are placed at the value they name.
    """
    out: list[ConfigError] = []
    registry = manager.registry
    for section, kind in COMPONENT_SECTIONS.items():
        config = profile.section(section)
        if config is None or section in profile.invalid:
            continue
        factory = registry.get(kind, config["type"]).factory
        checks = [getattr(factory, "validate", None)]
        if kind == "arm" and callable(getattr(factory, "model", None)):
            checks.append(lambda c, p, f=factory: f.model(c))
        for check in checks:
            if not callable(check):
                continue
            try:
                check(profile.component(section), profile)
            except ConfigError as exc:
                out.extend(place_error(profile, e) for e in exc.errors)
            except (ValueError, TypeError, KeyError, IndexError, ArithmeticError) as exc:
                out.append(
                    profile.error(
                        section,
                        f"{config['type']} refuses these values: {shown(str(exc))}",
                    )
                )
    return out


def _section_checks(profile: Profile, manager: PluginManager, clean: bool) -> list[ConfigError]:
    """The ``check`` of every section plugins registered, skipping sections of the wrong type."""
    out: list[ConfigError] = []
    for name, component in registered_sections(manager).items():
        check = component.factory.check
        if check is None or name in profile.invalid or name in PROFILE_KEYS:
            continue
        out += _checked(
            lambda check=check: check(profile),
            component.plugin,
            (f"check the {name}: section", f"the {name}: section's check"),
            clean,
            str(profile.source or profile.name),
        )
    return out


def _checked(
    call: Any, plugin: str, what: tuple[str, str], clean: bool, file: str
) -> list[ConfigError]:
    """The ConfigErrors a plugin's check returns or raises.

    ``what`` names the check in messages: ``failed to {what[0]}``, ``{what[1]} must
    return ConfigErrors``. An exception other than ConfigError is a plugin bug when
    the profile is otherwise valid (``clean``); else it follows from errors already
    reported and is dropped.
    """
    try:
        found = call()
    except ConfigError as exc:
        return list(exc.errors)
    except Exception as exc:  # noqa: BLE001 - a plugin's bug is reported, not raised
        if not clean:
            return []
        message = f"plugin {plugin!r} failed to {what[0]}: {type(exc).__name__}: {exc}"
        return [ConfigError(message, file=file)]
    return _as_errors(found, plugin, what[1], file)


def _as_errors(found: Any, plugin: str, what: str, file: str) -> list[ConfigError]:
    """What a plugin's check returned, as ConfigErrors; anything else is the plugin's mistake."""
    out: list[ConfigError] = []
    for item in found or ():
        if isinstance(item, ConfigError):
            out.extend(item.errors)
        else:
            out.append(
                ConfigError(
                    f"plugin {plugin!r}: {what} must return ConfigErrors, "
                    f"got {type(item).__name__}",
                    file=file,
                )
            )
    return out


def _plugin_checks(profile: Profile, manager: PluginManager, clean: bool) -> list[ConfigError]:
    """Every ``armtree_validate_profile`` implementation's errors, called through pluggy.

    A plugin that raises is left out and the hook called again, so one plugin's
    failure does not hide another's findings. An exception other than ConfigError
    is a plugin bug when the profile is otherwise valid (``clean``); else it follows
    from errors already reported and is dropped.
    """
    file = str(profile.source or profile.name)
    out: list[ConfigError] = []

    def raised(hook: str, plugin: str, exc: BaseException) -> None:
        if isinstance(exc, ConfigError):
            out.extend(exc.errors)
        elif clean:
            message = f"plugin {plugin!r} failed to check the profile: {type(exc).__name__}: {exc}"
            out.append(ConfigError(message, file=file))

    results = call_isolated(
        manager.pm, "armtree_validate_profile", raised, call_again=True, profile=profile
    )
    for found in reversed(results or []):
        out += _as_errors(found, plugin_of(found), "armtree_validate_profile", file)
    return out


def _plugins(
    data: MarkedDict, source: Path | None, errors: list[ConfigError]
) -> list[tuple[str, Mark | None]]:
    specs = data.get("plugins")
    if specs is None:
        return []
    if not isinstance(specs, list) or not all(isinstance(s, str) for s in specs):
        errors.append(
            error_at(
                "plugins: expected a list of module names or .py files", data.value_mark("plugins")
            )
        )
        return []
    out: list[tuple[str, Mark | None]] = []
    for i, spec in enumerate(specs):
        if spec.endswith(".py") and source is not None and not Path(spec).is_absolute():
            spec = str((source.parent / spec).resolve())
        # A list from an override or an include may be plain: its items' place is the list's.
        mark = specs.item_mark(i) if isinstance(specs, MarkedList) else data.value_mark("plugins")
        out.append((spec, mark))
    return out


def _validate(data: MarkedDict, manager: PluginManager, errors: list[ConfigError]) -> set[str]:
    """Check every section, appending to ``errors``; return the sections that had errors."""
    invalid: set[str] = set()

    def check(section: str, fn: Any, *args: Any) -> None:
        before = len(errors)
        fn(*args)
        if len(errors) > before:
            invalid.add(section)

    owned = registered_sections(manager)
    known = section_names(manager)
    for key in data:
        if key not in known:
            errors.append(
                error_at(
                    f"unknown profile section {shown(key)}{did_you_mean(str(key), known)}",
                    data.key_mark(key),
                )
            )
    for key in REQUIRED_SECTIONS:
        if key not in data:
            errors.append(error_at(f"the profile has no {shown(key)} section", data.mark))
    for key in ("profile", "description"):
        if key in data and not isinstance(data[key], str):
            errors.append(error_at(f"{key}: expected a string", data.value_mark(key)))
    try:
        registry = manager.registry
    except ConfigError as exc:
        errors.append(exc)
        return set(COMPONENT_SECTIONS)
    for section, kind in COMPONENT_SECTIONS.items():
        if data.get(section) is not None:
            check(section, _check_component, data, section, kind, registry, errors)
    invalid |= check_sections(data, Context(data, errors))
    for name, component in owned.items():
        if name in PROFILE_KEYS:
            continue  # armtree's own: the registry refuses the name (plugin_checks)
        problem = component.factory.type_problem(data.get(name))
        if problem is not None:
            errors.append(error_at(f"{name}: {problem}", data.value_mark(name)))
            invalid.add(name)
    return invalid


def _check_component(
    data: MarkedDict, section: str, kind: str, registry: Registry, errors: list[ConfigError]
) -> None:
    config = data[section]
    if not isinstance(config, MarkedDict):
        errors.append(
            error_at(
                f"{section}: expected a mapping with a type, e.g. {{type: NAME}}",
                data.value_mark(section),
            )
        )
        return
    ctype = config.get("type")
    if not isinstance(ctype, str):
        errors.append(
            error_at(
                f"{section}: needs a type (one of: {', '.join(registry.names(kind))})", config.mark
            )
        )
        return
    if not registry.has(kind, ctype):
        errors.append(
            error_at(
                f"{section}: unknown {kind} type {shown(ctype)}"
                f"{did_you_mean(ctype, registry.names(kind))}{registry.why_unknown(kind, ctype)}",
                config.value_mark("type"),
            )
        )
        return
    params = {p.name: p for p in registry.get(kind, ctype).params}
    if not params:
        return
    swapped_from = getattr(config, "swapped_from", None)
    for key, value in list(config.items()):
        if key == "type":
            continue
        param = params.get(key)
        if param is None and swapped_from and not _from_override(config.key_mark(key)):
            if not hasattr(config, "dropped"):
                config.dropped = {}
            config.dropped[key] = (value, config.key_mark(key))
            del config[key]
            continue
        if param is None:
            errors.append(
                error_at(
                    f"{section}: {ctype} has no parameter {shown(key)}{did_you_mean(str(key), params)}",
                    config.key_mark(key),
                )
            )
            continue
        if value is None and param.default is None and not param.required:
            continue  # null: "none", where nothing is the default (arm.gripper: null)
        try:
            check_value(param, value)
        except ValueError as exc:
            errors.append(error_at(f"{section}.{key}: {exc}", config.value_mark(key)))
    for name, param in params.items():
        if param.required and name not in config:
            errors.append(
                error_at(
                    f"{section}: {ctype} needs parameter {shown(name)} ({param.doc})", config.mark
                )
            )


def _from_override(mark: Mark | None) -> bool:
    return mark is not None and mark.file.startswith("--set ")


def tag_spec(role: str, spec: Mapping[str, Any]) -> TagSpec:
    """One checked ``tags:`` entry as a :class:`TagSpec`, its ``family_ids`` as tuples."""
    ids = (spec["id"],) if "id" in spec else tuple(spec.get("ids", ()))
    family_ids = {
        str(family): tuple(int(i) for i in (value if isinstance(value, (list, tuple)) else [value]))
        for family, value in (spec.get("family_ids") or {}).items()
    }
    return TagSpec(role, tuple(int(i) for i in ids), float(spec["size_mm"]), family_ids)


def _flatten_marks(
    data: Any, prefix: str = "", out: dict[str, Mark] | None = None
) -> dict[str, Mark]:
    out = {} if out is None else out
    if isinstance(data, MarkedDict):
        if data.mark is not None and prefix not in out:
            out[prefix] = data.mark
        for key, value in data.items():
            path = f"{prefix}.{key}" if prefix else str(key)
            mark = data.value_mark(key)
            if mark is not None:
                out[path] = mark
            _flatten_marks(value, path, out)
    elif isinstance(data, MarkedList):
        for i, value in enumerate(data):
            path = f"{prefix}.{i}"
            mark = data.item_mark(i)
            if mark is not None:
                out[path] = mark
            _flatten_marks(value, path, out)
    return out


def _remark(data: Any, marks: Mapping[str, Mark], prefix: str) -> Any:
    """Rebuild marked containers from plain data and a path->mark table."""
    if isinstance(data, dict):
        out = MarkedDict(mark=marks.get(prefix))
        for key, value in data.items():
            path = f"{prefix}.{key}" if prefix else str(key)
            out[key] = _remark(value, marks, path)
            if path in marks:
                out.key_marks[key] = out.value_marks[key] = marks[path]
        return out
    if isinstance(data, list):
        items = MarkedList(
            [_remark(v, marks, f"{prefix}.{i}") for i, v in enumerate(data)], mark=marks.get(prefix)
        )
        items.item_marks = [marks.get(f"{prefix}.{i}") for i in range(len(data))]
        return items
    return data


def arm_grips(registry: Registry, profile: AnyProfile) -> str | bool | None:
    """What the profile's arm holds things with (its factory's ``grips_with(config)``):
    ``"suction"``, ``"gripper"``, None for nothing, True when the arm plugin does not say."""
    config = component_config(profile, "arm")
    name = config.get("type") if isinstance(config, Mapping) else None
    if not isinstance(name, str) or not registry.has("arm", name):
        return True
    grips = getattr(registry.get("arm", name).factory, "grips_with", None)
    if not callable(grips):
        return True
    try:
        return grips(dict(config))
    except (ConfigError, ValueError, TypeError, KeyError):
        return True  # the profile's own checks report why
