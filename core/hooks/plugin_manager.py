"""Finding, loading and checking plugins, and the registry of what they provide.

The only global state in armtree is the plugin manager a process builds; tests
and embedding applications can make their own with :class:`PluginManager`.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import inspect
import os
import sys
import traceback
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pluggy

from armtree.config.constructor_params import declared_params
from armtree.errors import ConfigError, Mark, did_you_mean

from . import hookspecs
from .hook_calls import attributing, call_isolated, plugin_of, raised_at, type_name
from .plugin_checks import hook_name_problems, interface_problems, version_problem

ENTRY_POINT_GROUP = "armtree"
DISABLE_AUTOLOAD_ENV = "ARMTREE_DISABLE_PLUGIN_AUTOLOAD"
OWN_DISTRIBUTION = "armtree"

#: Component kind -> registration hook.
KINDS: dict[str, str] = {
    "behaviour": "armtree_behaviours",
    "arm": "armtree_arms",
    "camera": "armtree_cameras",
    "tracker": "armtree_trackers",
    "planner": "armtree_planners",
    "command": "armtree_commands",
    "predicate": "armtree_predicates",
    "profile_section": "armtree_profile_sections",
}
#: Every hook a plugin may implement.
HOOK_NAMES = frozenset(
    name
    for name in dir(hookspecs)
    if name.startswith("armtree_") and callable(getattr(hookspecs, name))
)
#: Hooks whose results must name the plugin behind them (in errors and ``armtree plugins``).
ATTRIBUTED_HOOKS = frozenset({*KINDS.values(), "armtree_validate_profile"})


@dataclass(frozen=True)
class Component:
    """One registered factory: its kind, name, and the plugin and distribution it came from."""

    kind: str
    name: str
    factory: Any
    plugin: str
    distribution: str | None

    @property
    def summary(self) -> str:
        """The factory's own ``summary`` text, else the first line of its docstring."""
        summary = getattr(self.factory, "summary", None)
        if isinstance(summary, str):
            return summary
        doc = getattr(self.factory, "__doc__", None) or ""
        return doc.strip().splitlines()[0] if doc.strip() else ""

    @property
    def params(self) -> tuple[Any, ...]:
        """The factory's parameters: its ``PARAMS``, or a plain py_trees behaviour's constructor's."""
        return declared_params(self.factory)


class _Pluggy(pluggy.PluginManager):
    """pluggy's manager that, as pytest does, takes any ``armtree_*`` function as a hookimpl.

    A hook function whose ``@armtree.hookimpl`` was forgotten still works, and one
    whose name is misspelt is reported by ``check_pending`` instead of being
    silently ignored.
    """

    def register(self, plugin: Any, name: str | None = None) -> str | None:
        """Register ``plugin``; its implementations of :data:`ATTRIBUTED_HOOKS` return
        results that name it (:func:`armtree.hooks.hook_calls.attributing`)."""
        registered = super().register(plugin, name)
        if registered is None:
            return None
        for hook_name in ATTRIBUTED_HOOKS:
            caller = getattr(self.hook, hook_name, None)
            for impl in caller.get_hookimpls() if caller is not None else ():
                if impl.plugin is plugin and not (impl.wrapper or impl.hookwrapper):
                    impl.function = attributing(impl.function, registered)
        return registered

    def parse_hookimpl_opts(self, plugin: Any, name: str) -> Any:
        opts = super().parse_hookimpl_opts(plugin, name)
        if opts is None and name.startswith("armtree_"):
            method = getattr(plugin, name, None)
            if inspect.isroutine(method):
                return {}
        return opts


class PluginManager:
    """pluggy's manager plus armtree's rules for finding and checking plugins.

    ``blocked`` names plugins not to load (``-p no:NAME``); ``autoload=False``
    (or the environment variable ``ARMTREE_DISABLE_PLUGIN_AUTOLOAD``) skips
    entry points of other distributions, keeping armtree's own built-ins.

    An installed plugin (an entry point) that is broken (it does not import, a
    hook's name is misspelt, a component misses its interface) blocks only what
    needs it: it is left out with a one-line warning (:attr:`warnings`, printed to
    stderr), and a tree or profile that names a component it would have provided
    is refused with the reason. A plugin given by ``--plugin`` or a ``plugins:``
    list is the user's choice for this run: its problems are errors.
    """

    def __init__(self, blocked: Iterable[str] = (), autoload: bool | None = None) -> None:
        self.pm = _Pluggy("armtree")
        self.pm.add_hookspecs(hookspecs)
        self.blocked = set(blocked)
        if autoload is None:
            autoload = not os.environ.get(DISABLE_AUTOLOAD_ENV)
        self.autoload = autoload
        self._distributions: dict[str, str | None] = {}
        self._registry: Registry | None = None
        self._partial: dict[str, Registry] = {}
        #: ``--plugin`` / ``plugins:`` specs loaded into this manager, in order.
        self.specs: list[str] = []
        #: True for managers shared through :func:`get_plugin_manager` (never mutated).
        self.shared = False
        #: The plugins registered from entry points (installed distributions).
        self.installed: set[str] = set()
        #: Installed plugins left out, with why: ``{name: message}``.
        self.broken: dict[str, str] = {}
        #: Components of installed plugins left out: ``{(kind, name): error}``.
        self.refused: dict[tuple[str, str], ConfigError] = {}
        #: The warnings given about broken installed plugins, in order.
        self.warnings: list[str] = []

    def warn(self, text: str) -> None:
        """Note ``text`` in :attr:`warnings` and print it as one line on stderr (once a
        process: every manager of a process loads the same entry points)."""
        self.warnings.append(text)
        if text not in _WARNED:
            _WARNED.add(text)
            print(f"warning: {text}", file=sys.stderr, flush=True)

    def _left_out(self, name: str, error: ConfigError) -> None:
        where = f"{error.file}:{error.line}: " if error.file and error.line else ""
        self.broken[name] = f"{where}{error.message}"
        first = error.message.split(". ")[0]
        self.warn(
            f"installed plugin {name!r} is left out: {where}{first} (trees that use it are "
            f"refused; -p no:{name} skips it)"
        )

    @property
    def hook(self) -> Any:
        """pluggy's hook relay: ``manager.hook.armtree_tick(run=run)``."""
        return self.pm.hook

    def load_entry_points(self) -> None:
        """Load every ``armtree`` entry point one by one.

        One that fails to import or to validate is left out with a warning naming
        it, its distribution and the fix (:attr:`broken`); the others load.
        """
        for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
            dist = ep.dist.name if ep.dist is not None else None
            if ep.name in self.blocked or self.pm.has_plugin(ep.name):
                continue
            if not self.autoload and dist != OWN_DISTRIBUTION:
                continue
            try:
                plugin = ep.load()
            except (Exception, SystemExit) as exc:  # noqa: BLE001 - any import failure alike
                self._left_out(
                    ep.name,
                    ConfigError(
                        f"plugin {ep.name!r} (entry point {ep.value!r} of distribution "
                        f"{dist or 'unknown'}) failed to import: {_import_failure(exc)}. "
                        f"Fix or reinstall {dist or 'the distribution'}, or skip it with "
                        f"-p no:{ep.name}",
                        file=f"entry point {ep.name}",
                    ),
                )
                continue
            try:
                self.register(plugin, ep.name, dist)
            except ConfigError as exc:
                self._left_out(ep.name, exc)
                continue
            self.installed.add(ep.name)

    def load(self, spec: str, where: Mark | None = None) -> None:
        """Load a plugin given as a module name or a ``.py`` file path."""
        name = Path(spec).stem if spec.endswith(".py") else spec
        if name in self.blocked or self.pm.has_plugin(name):
            return
        try:
            if spec.endswith(".py") or os.sep in spec:
                path = Path(spec)
                if not path.is_file():
                    raise FileNotFoundError(f"no file {spec}")
                mod_name = f"armtree_plugin_{path.stem}"
                loader_spec = importlib.util.spec_from_file_location(mod_name, path)
                assert loader_spec is not None and loader_spec.loader is not None
                module = importlib.util.module_from_spec(loader_spec)
                sys.modules[mod_name] = module
                loader_spec.loader.exec_module(module)
            else:
                module = importlib.import_module(spec)
        except (Exception, SystemExit) as exc:  # noqa: BLE001 - sys.exit() at import too
            raise ConfigError(
                f"plugin {spec!r} failed to import: {_import_failure(exc)}. "
                "Give an importable module name or a path to a .py file",
                file=where.file if where else None,
                line=where.line if where else None,
                column=where.column if where else None,
            ) from exc
        self.register(module, name, None)
        self.specs.append(spec)

    def extended(
        self, plugins: Iterable[str], where: dict[str, Mark] | None = None
    ) -> PluginManager:
        """This manager with ``plugins`` added (module names or ``.py`` paths).

        A shared manager is left as it is and the shared manager with the longer
        plugin list is returned; a private one is extended in place. ``where``
        maps a spec to its position in a tree or profile, for error messages.
        """
        new = [spec for spec in plugins if spec not in self.specs]
        if not new:
            return self
        if self.shared:
            return get_plugin_manager(
                [*self.specs, *new], self.blocked, autoload=self.autoload, where=where
            )
        for spec in new:
            self.load(spec, (where or {}).get(spec))
        return self

    def register(self, plugin: Any, name: str, distribution: str | None = None) -> None:
        """Register one plugin object, turning pluggy's validation errors into ConfigErrors.

        A plugin that declares armtree versions it does not support
        (``ARMTREE_REQUIRES``, or its distribution's requirement on armtree) is refused.
        """
        mismatch = version_problem(plugin, name, distribution)
        if mismatch is not None:
            raise mismatch
        misspelt = hook_name_problems(plugin, name, HOOK_NAMES)
        if misspelt:
            first = misspelt[0]
            raise ConfigError(first.message, first.file, first.line, errors=misspelt)
        try:
            self.pm.register(plugin, name=name)
            self.pm.check_pending()
        except pluggy.PluginValidationError as exc:
            if self.pm.is_registered(plugin):
                self.pm.unregister(plugin)
            where = f" from distribution {distribution}" if distribution else ""
            raise ConfigError(
                f"plugin {name!r}{where} is invalid: {exc}. Hook names must be ones listed in "
                "armtree.hooks.hookspecs and their arguments must match the specification; "
                f"fix the plugin or skip it with -p no:{name}",
                file=getattr(plugin, "__file__", None),
            ) from exc
        self._distributions[name] = distribution
        self._registry = None
        self._partial = {}

    @property
    def registry(self) -> Registry:
        """Every registered component, built on first use and after each new plugin.

        Raises one :class:`ConfigError` listing every component that does not fit
        its interface (:func:`armtree.hooks.plugin_checks.interface_problems`).
        """
        if self._registry is None:
            self._registry = self._checked(KINDS)
        return self._registry

    def components(self, kind: str) -> Registry:
        """The registry of one kind of component only (the others empty), for commands
        that need no more: ``armtree sweep`` finds its command without calling every
        plugin's behaviours, arms and cameras."""
        if self._registry is not None:
            return self._registry
        if kind not in self._partial:
            self._partial[kind] = self._checked((kind,))
        return self._partial[kind]

    def _checked(self, kinds: Iterable[str]) -> Registry:
        components = self._collect(kinds)
        problems = []
        for found in components.values():
            for name, component in list(found.items()):
                errors = [problem.error() for problem in interface_problems(component)]
                if not errors:
                    continue
                if component.plugin not in self.installed:
                    problems.extend(errors)
                    continue
                # An installed plugin's misfit blocks only the trees that name it.
                del found[name]
                key = (component.kind, name)
                if key not in self.refused:
                    self.refused[key] = errors[0]
                    self.warn(
                        f"{component.kind} {name!r} of installed plugin {component.plugin!r} is "
                        f"left out: {errors[0].format().split('. ')[0]}"
                    )
        if problems:
            first = problems[0]
            raise ConfigError(first.message, file=first.file, line=first.line, errors=problems)
        return Registry(
            {kind: components.get(kind, {}) for kind in KINDS}, self.refused, self.broken
        )

    def _collect(self, kinds: Iterable[str]) -> dict[str, dict[str, Component]]:
        """The registration hooks of ``kinds`` called through pluggy; each dict names its plugin."""
        found: dict[str, dict[str, Component]] = {kind: {} for kind in kinds}
        for kind in kinds:
            hook_name = KINDS[kind]
            results = self._registrations(hook_name)
            # pluggy calls the last registered first: reversed, the first registered wins.
            for result in reversed(results or []):
                plugin_name = plugin_of(result)
                if not isinstance(result, dict):
                    raise ConfigError(
                        f"plugin {plugin_name!r}: {hook_name}() must return a dict of "
                        f"{{name: factory}}, got {type_name(result)}"
                    )
                for name, factory in result.items():
                    if name in found[kind]:
                        other = found[kind][name]
                        raise ConfigError(
                            f"{kind} {name!r} is registered twice: by plugin {other.plugin!r} "
                            f"({other.distribution or 'not installed'}) and by plugin "
                            f"{plugin_name!r} ({self._distributions.get(plugin_name) or 'not installed'}). "
                            f"Rename one, or block one with -p no:{plugin_name}"
                        )
                    found[kind][name] = Component(
                        kind, name, factory, plugin_name, self._distributions.get(plugin_name)
                    )
        return found

    def _registrations(self, hook_name: str) -> list[Any]:
        """What every plugin's registration hook ``hook_name`` returns, called through pluggy.

        A hook that raises is the plugin's error at the line it raised: an installed
        plugin is left out with a warning (it blocks only the trees that use it); one
        the user named for this run (``--plugin``, ``plugins:``) is an error.
        """
        raised: list[tuple[str, ConfigError]] = []

        def on_error(hook: str, plugin: str, exc: BaseException) -> None:
            impls = [
                i for i in getattr(self.pm.hook, hook).get_hookimpls() if i.plugin_name == plugin
            ]
            file, line = raised_at(exc, impls[0].function if impls else None)
            message = (
                f"plugin {plugin!r}: {hook}() raised {type(exc).__name__}: {exc}. Fix the "
                f"plugin, or skip it with -p no:{plugin}"
            )
            text = "".join(traceback.format_exception(exc))
            raised.append((plugin, ConfigError(message, file=file, line=line, traceback=text)))

        results = call_isolated(self.pm, hook_name, on_error, call_again=True) or []
        chosen = []
        for plugin, error in raised:
            if plugin in self.installed:
                self.pm.unregister(name=plugin)
                self.installed.discard(plugin)
                self._left_out(plugin, error)
            else:
                chosen.append(error)
        if chosen:
            first = chosen[0]
            raise ConfigError(first.message, file=first.file, line=first.line, errors=chosen)
        return results


def _import_failure(exc: BaseException) -> str:
    """What went wrong importing a plugin: the exception, or its exit by ``sys.exit()``."""
    if isinstance(exc, SystemExit):
        return f"it called sys.exit({exc.code!r}) while being imported"
    return f"{type(exc).__name__}: {exc}"


class Registry:
    """Lookup of registered components by kind and name, with did-you-mean errors.

    ``refused`` holds the components of installed plugins left out for missing
    their interface, ``broken`` the installed plugins left out whole (``{name:
    why}``): a name that is unknown says why it may be (:meth:`why_unknown`).
    """

    def __init__(
        self,
        components: dict[str, dict[str, Component]],
        refused: dict[tuple[str, str], ConfigError] | None = None,
        broken: dict[str, str] | None = None,
    ) -> None:
        self._components = components
        self._refused = dict(refused or {})
        self._broken = dict(broken or {})

    def why_unknown(self, kind: str, name: str) -> str:
        """Why ``name`` is no ``kind`` here, when a broken installed plugin may be why:
        ``"; ..."`` to append to the message, else ``""``."""
        refused = self._refused.get((kind, name))
        if refused is not None:
            return f"; it is left out: {refused.format()}"
        if not self._broken:
            return ""
        plugins = "; ".join(f"{plugin!r}: {why}" for plugin, why in self._broken.items())
        return f"; an installed plugin that may provide it did not load ({plugins})"

    def names(self, kind: str) -> list[str]:
        """Sorted names registered for ``kind``."""
        return sorted(self._components[kind])

    def all(self) -> list[Component]:
        """Every component, sorted by kind then name."""
        return [c for kind in KINDS for _, c in sorted(self._components[kind].items())]

    def has(self, kind: str, name: str) -> bool:
        """True when ``name`` is registered for ``kind``."""
        return name in self._components[kind]

    def instances(self, kind: str, reserved: Iterable[str] = ()) -> dict[str, Any]:
        """``{name: object}`` of ``kind``, a class registered as a factory made once.

        A name in ``reserved`` (armtree's own of that kind) is an error naming the plugin.
        """
        out = {}
        reserved = set(reserved)
        for name in self.names(kind):
            component = self._components[kind][name]
            if name in reserved:
                raise ConfigError(
                    f"{kind} {name!r} of plugin {component.plugin!r} clashes with armtree's own "
                    f"{name!r}; rename it, or block the plugin with -p no:{component.plugin}"
                )
            factory = component.factory
            out[name] = factory() if isinstance(factory, type) else factory
        return out

    def get(self, kind: str, name: str, where: Mark | None = None) -> Component:
        """The component, or a ConfigError with a did-you-mean suggestion at ``where``."""
        try:
            return self._components[kind][name]
        except KeyError:
            raise ConfigError(
                f"unknown {kind} {name!r}{did_you_mean(name, self.names(kind))}"
                f"{self.why_unknown(kind, name)}",
                file=where.file if where else None,
                line=where.line if where else None,
                column=where.column if where else None,
            ) from None


#: Managers shared by the process, keyed by (plugins, blocked, autoload). This cache is
#: the one piece of global state: loading entry points once per process keeps
#: repeated loads (tests, benchmarks, includes) cheap.
_SHARED: dict[tuple[tuple[str, ...], tuple[str, ...], bool], PluginManager] = {}
#: The warnings about broken installed plugins printed so far, so each is printed once.
_WARNED: set[str] = set()


def get_plugin_manager(
    plugins: Iterable[str] = (),
    blocked: Iterable[str] = (),
    autoload: bool | None = None,
    where: dict[str, Mark] | None = None,
) -> PluginManager:
    """The process-wide manager for these plugins and blocks, built on first use.

    ``autoload=None`` reads ``ARMTREE_DISABLE_PLUGIN_AUTOLOAD`` now. Treat the
    result as read-only: use :meth:`PluginManager.extended` to add plugins.
    ``where`` positions import errors of ``plugins`` given in a file.
    """
    if autoload is None:
        autoload = not os.environ.get(DISABLE_AUTOLOAD_ENV)
    plugins = tuple(plugins)
    key = (plugins, tuple(sorted(set(blocked))), bool(autoload))
    manager = _SHARED.get(key)
    if manager is None:
        manager = PluginManager(blocked=key[1], autoload=autoload)
        manager.load_entry_points()
        for spec in plugins:
            manager.load(spec, (where or {}).get(spec))
        manager.shared = True
        _SHARED[key] = manager
    return manager


def clear_plugin_managers() -> None:
    """Forget the shared managers and the warnings given (for tests that install or change
    plugins)."""
    _SHARED.clear()
    _WARNED.clear()


def make_plugin_manager(
    plugins: Iterable[str] = (), blocked: Iterable[str] = (), autoload: bool | None = None
) -> PluginManager:
    """A plugin manager with entry points loaded and ``plugins`` (modules or files) added."""
    manager = PluginManager(blocked=blocked, autoload=autoload)
    manager.load_entry_points()
    for spec in plugins:
        manager.load(spec)
    return manager
