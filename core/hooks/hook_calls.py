"""Calling a hook through pluggy so that one plugin's exception does not silence the others.

Plugins are called as pluggy calls them (``pm.hook.armtree_x(...)``): wrappers wrap,
``tryfirst`` / ``trylast`` order, ``firstresult`` hooks stop at the first answer.
When an implementation raises, the exception is handed to ``on_error`` with the
plugin that raised it, and the hook is called again without that plugin, so the
rest still hear of the event.
"""

from __future__ import annotations

import functools
import inspect
import os
import sysconfig
import traceback as tb_module
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pluggy
import py_trees

from armtree.errors import ConfigError

#: ``on_error(hook name, plugin name, exception)``.
ErrorHandler = Callable[[str, str, BaseException], None]


class PluginDict(dict):
    """A hook implementation's ``dict`` result that names the plugin it came from (``.plugin``)."""

    plugin: str


class PluginList(list):
    """A hook implementation's ``list`` result that names the plugin it came from (``.plugin``)."""

    plugin: str


def attributing(function: Callable[..., Any], plugin: str) -> Callable[..., Any]:
    """``function`` (a hook implementation) returning its dict or list as a
    :class:`PluginDict` / :class:`PluginList` naming ``plugin``.

    pluggy calls it as it called ``function`` (positional arguments in the order of
    its parameters), so wrappers and ordering work as for any implementation, and a
    wrapper sees a plain dict or list.
    """

    @functools.wraps(function)
    def call(*args: Any) -> Any:
        result = function(*args)
        if isinstance(result, dict):
            result = PluginDict(result)
        elif isinstance(result, list):
            result = PluginList(result)
        else:
            return result
        result.plugin = plugin
        return result

    return call


def plugin_of(result: Any, default: str = "a hook wrapper") -> str:
    """The plugin whose implementation returned ``result``; ``default`` for a result
    that no attributed implementation returned (a wrapper added it)."""
    return getattr(result, "plugin", None) or default


def type_name(result: Any) -> str:
    """The name of ``result``'s type as its plugin returned it (``dict``, not PluginDict)."""
    if isinstance(result, PluginDict):
        return "dict"
    if isinstance(result, PluginList):
        return "list"
    return type(result).__name__


def has_implementations(pm: pluggy.PluginManager | None, name: str) -> bool:
    """True when some registered plugin implements hook ``name``."""
    return pm is not None and bool(getattr(pm.hook, name).get_hookimpls())


def call_isolated(
    pm: pluggy.PluginManager | None,
    name: str,
    on_error: ErrorHandler,
    *,
    call_again: bool = False,
    **kwargs: Any,
) -> Any:
    """Call hook ``name`` through pluggy; a plugin that raises is reported and left out.

    Returns what pluggy returns (a list of results, or the first result of a
    ``firstresult`` hook) from the last call, the one no plugin raised in.
    After an exception the hook is called again without the plugin that raised.
    Plain implementations that already ran in the failed call are left out of the
    next one as well, unless ``call_again`` (for hooks whose results are wanted
    and whose implementations have no side effects, such as checks). An exception
    that cannot be traced to a plugin is reported under ``"?"`` and ends the call.
    """
    if pm is None:
        return None
    caller = getattr(pm.hook, name)
    removed: list[Any] = []
    while True:
        try:
            return caller(**kwargs)
        except Exception as exc:  # noqa: BLE001 - a plugin must not silence the others
            impls = getattr(pm.hook, name).get_hookimpls()
            culprit = _raiser(impls, exc)
            if culprit is None or culprit.plugin in removed:
                on_error(name, "?", exc)
                return None
            on_error(name, pm.get_name(culprit.plugin) or repr(culprit.plugin), exc)
            if _is_wrapper(culprit):
                # A wrapper that raised has decided the call's outcome for everyone inside it.
                return None
            removed.append(culprit.plugin)
            if not call_again:
                removed.extend(_ran_before(impls, culprit))
            caller = pm.subset_hook_caller(name, remove_plugins=removed)


def _raiser(impls: list[Any], exc: BaseException) -> Any:
    """The implementation deepest in ``exc``'s traceback: the one that raised it.

    A frame matches an implementation by its code and, for a method, by its ``self``,
    so two instances of one plugin class are told apart.
    """
    found = None
    tb = exc.__traceback__
    while tb is not None:
        frame = tb.tb_frame
        for impl in impls:
            function = getattr(impl.function, "__wrapped__", impl.function)
            if getattr(function, "__code__", None) is not frame.f_code:
                continue
            owner = getattr(function, "__self__", None)
            if owner is None or frame.f_locals.get("self") is owner:
                found = impl
                break
        tb = tb.tb_next
    return found


def _is_wrapper(impl: Any) -> bool:
    return bool(impl.hookwrapper or getattr(impl, "wrapper", False))


def _ran_before(impls: list[Any], culprit: Any) -> list[Any]:
    """Plugins whose plain implementations pluggy called before ``culprit`` (it calls
    the list of implementations from its end)."""
    index = impls.index(culprit)
    return [impl.plugin for impl in impls[index + 1 :] if not _is_wrapper(impl)]


def raised_at(exc: BaseException, factory: Any) -> tuple[str | None, int | None]:
    """Where in a plugin's code ``exc`` was raised: the innermost frame in ``factory``'s
    file, else the innermost outside armtree's core and Python's own library, else where
    ``factory`` is defined."""
    own = _source_file(factory)
    frames = tb_module.extract_tb(exc.__traceback__)
    mine = [f for f in frames if own is not None and f.filename == own]
    if not mine:
        mine = [f for f in frames if not f.filename.startswith(_NOT_PLUGINS)]
    if mine:
        return mine[-1].filename, mine[-1].lineno
    if own is None:
        return None, None
    try:
        return own, inspect.getsourcelines(factory)[1]
    except (OSError, TypeError):
        return own, None


def _source_file(factory: Any) -> str | None:
    try:
        return inspect.getsourcefile(inspect.unwrap(factory))
    except TypeError:
        return None


#: Folders whose frames are not a plugin's code: armtree's core, py_trees, Python's library.
_NOT_PLUGINS = tuple(
    str(folder) + os.sep
    for folder in (
        Path(__file__).resolve().parents[1],  # the armtree package (core/)
        Path(py_trees.__file__).resolve().parent,
        Path(pluggy.__file__).resolve().parent,
        sysconfig.get_paths()["stdlib"],
    )
)


def plugin_failure(what: str, component: Any, exc: BaseException) -> ConfigError:
    """The error for a plugin's code raising ``exc`` while doing ``what`` ("arm 'x': its
    factory"): the exception's type and text, the plugin, the file and line it was
    raised at, and the traceback ``--debug`` shows."""
    file, line = raised_at(exc, component.factory)
    return ConfigError(
        f"{what} (plugin {component.plugin!r}) raised {type(exc).__name__}: {exc}. Fix the "
        f"plugin, or skip it with -p no:{component.plugin}",
        file=file,
        line=line,
        traceback="".join(tb_module.format_exception(exc)),
    )
