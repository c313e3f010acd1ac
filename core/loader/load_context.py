"""What one tree load shares among its collaborators: where it is in the include chain
(:class:`LoadContext`), the positioned errors it collects (:class:`LoadErrors`) and the
files it has parsed (:class:`TreeFiles`). See :mod:`armtree.loader.tree_loader`."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from armtree.config.yamlio import MarkedDict, error_at, load_yaml_file
from armtree.errors import ConfigError, Mark, did_you_mean, shown


@dataclass
class LoadContext:
    """Where the loader is: the file, its parameters and the include chain."""

    file: Path
    params: dict[str, Any] = field(default_factory=dict)
    stack: tuple[Path, ...] = ()
    included_from: Mark | None = None
    #: Blackboard namespace of this subtree instance ("" for the shared one).
    namespace: str = ""


class LoadErrors:
    """Every problem one load finds, each with its file, line and column.

    :meth:`error` places a message at a mark in the context's file (naming the
    include that brought the file in); :meth:`fail` gives them all as one
    :class:`ConfigError`.
    """

    def __init__(self) -> None:
        self.found: list[ConfigError] = []
        #: Errors reported before the others, in the order found.
        self.leading: list[ConfigError] = []

    def __len__(self) -> int:
        return len(self.found) + len(self.leading)

    def error(
        self,
        message: str,
        mark: Mark | None,
        ctx: LoadContext | None = None,
        traceback: str | None = None,
    ) -> None:
        """Record ``message`` at ``mark``, in ``ctx``'s file when the mark names none;
        ``traceback``: the text of what a plugin's code raised, for ``--debug``."""
        if ctx is not None and ctx.included_from is not None:
            message = f"{message} (included from {ctx.included_from})"
        found = error_at(message, mark, str(ctx.file) if ctx else None)
        found.traceback = traceback
        self.found.append(found)

    def unknown_keys(
        self, mapping: MarkedDict, known: Sequence[str], what: str, ctx: LoadContext
    ) -> bool:
        """Record ``what KEY`` (with did-you-mean) at each key of ``mapping`` not in ``known``;
        True when there is none."""
        unknown = [key for key in mapping if key not in known]
        for key in unknown:
            self.error(
                f"{what} {shown(key)}{did_you_mean(str(key), known)}", mapping.key_mark(key), ctx
            )
        return not unknown

    def extend(self, errors: Iterable[ConfigError], *, first: bool = False) -> None:
        """Record errors already positioned (a profile's, a plugin's, a parser's);
        ``first``: before all others (a plugin that did not load: the rest follows from it)."""
        (self.leading if first else self.found).extend(errors)

    def fail(self, files: Iterable[Path]) -> ConfigError:
        """One error listing all, ordered by file (in the order ``files`` gives, then other
        files as their errors came: a profile's, a plugin's), line and column."""
        order = {str(path): i for i, path in enumerate(files)}
        for error in self.found:
            order.setdefault(error.file or "", len(order))
        errors = self.leading + sorted(
            self.found,
            key=lambda e: (order.get(e.file or "", len(order)), e.line or 0, e.column or 0),
        )
        # A subtree included twice reports the same problem at the same place once.
        errors = list({(e.file, e.line, e.column, e.message): e for e in errors}.values())
        first = errors[0]
        return ConfigError(first.message, first.file, first.line, first.column, errors)


#: ``read(path)``: a tree file in another format as the data its YAML would give, or
#: None to read it as YAML (the plugins' ``armtree_read_tree``).
ReadTree = Callable[[Path], Any]

#: Suffixes always read as YAML.
YAML_SUFFIXES = (".yaml", ".yml")


class TreeFiles:
    """The tree files of one load, each parsed once, in the order they were first read.

    A file whose suffix is not ``.yaml`` or ``.yml`` is offered to ``read`` first
    (a plugin's format, such as BehaviorTree.CPP XML); a file nobody claims is YAML.
    """

    def __init__(self, errors: LoadErrors, read: ReadTree | None = None) -> None:
        self._errors = errors
        self._read = read
        self._parsed: dict[Path, Any] = {}
        self._failed: set[Path] = set()

    def parse(self, path: Path) -> Any:
        """The file's data; None (its error recorded once) when it does not parse."""
        if path not in self._parsed:
            try:
                data = None
                if self._read is not None and path.suffix.lower() not in YAML_SUFFIXES:
                    data = self._read(path)
                self._parsed[path] = load_yaml_file(path) if data is None else data
            except ConfigError as exc:
                self._errors.extend(exc.errors)
                self._parsed[path] = None
                self._failed.add(path)
        return self._parsed[path]

    def failed(self, path: Path) -> bool:
        """True when ``path`` was read and did not parse (its error is recorded)."""
        return path in self._failed

    def order(self) -> list[Path]:
        """The files read so far, first read first."""
        return list(self._parsed)
