"""The hook reference of docs/plugins.md, generated from :mod:`armtree.hooks.hookspecs`.

Each hook's signature and docstring, grouped under the section comments of
``hookspecs.py`` (``# Registration: ...``), in source order, as Markdown. The
docstrings' reST (``code``, :class:`x`, ``:param a:``, ``:return:``) becomes
Markdown. ``armtree hooks`` prints it; ``armtree hooks --update docs/plugins.md``
rewrites the part of that file between :data:`BEGIN` and :data:`END`, and a test
fails while the file and the hookspecs disagree.
"""

from __future__ import annotations

import argparse
import inspect
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from armtree.errors import ConfigError
from armtree.hooks import hookspecs

from .docgen import replace_generated

BEGIN = (
    "<!-- hook reference: generated from core/hooks/hookspecs.py by "
    "`armtree hooks --update docs/plugins.md`; edit the docstrings, not this part -->"
)
END = "<!-- end of the hook reference -->"

_SECTION = re.compile(r"^# -{10,}\n((?:#.*\n)+?)# -{10,}\n", re.M)


def hook_reference() -> str:
    """The whole reference as Markdown (no markers)."""
    source = inspect.getsource(hookspecs)
    sections = [(m.start(), _comment_text(m.group(1))) for m in _SECTION.finditer(source)]
    hooks = [
        (source.index(f"\ndef {name}("), name, function)
        for name, function in vars(hookspecs).items()
        if name.startswith("armtree_") and callable(function)
    ]
    # A section is its comment's text, a hook its name and function; both in source order.
    entries: list[tuple[int, str | tuple[str, Callable[..., object]]]] = [
        (pos, text) for pos, text in sections
    ]
    entries += [(pos, (name, f)) for pos, name, f in hooks]
    out: list[str] = []
    for _, value in sorted(entries, key=lambda item: item[0]):
        if isinstance(value, str):
            title, _, rest = value.partition(":")
            out.append(f"### {title.strip()}\n")
            if rest.strip():
                out.append(_sentence(rest.strip()) + "\n")
        else:
            name, function = value
            out.append(_hook(name, function))
    return "\n".join(out).rstrip() + "\n"


def _comment_text(block: str) -> str:
    return " ".join(line.lstrip("#").strip() for line in block.splitlines()).strip()


def _sentence(text: str) -> str:
    text = _markdown(text)
    return text[:1].upper() + text[1:]


def _hook(name: str, function: Any) -> str:
    signature = inspect.signature(function)
    params = ", ".join(
        f"{p.name}: {p.annotation}" if p.annotation is not inspect.Parameter.empty else p.name
        for p in signature.parameters.values()
    )
    returns = signature.return_annotation
    arrow = f" -> {returns}" if returns is not inspect.Signature.empty else ""
    doc = inspect.getdoc(function) or ""
    return f"#### `{name}({params}){arrow}`\n\n{_docstring(doc)}\n"


def _docstring(doc: str) -> str:
    """reST field lists and roles as Markdown; paragraphs kept, field lines joined."""
    lines = doc.splitlines()
    out: list[str] = []
    field: list[str] | None = None
    for line in lines:
        match = re.match(r"^:(param\s+(\w+)|return|raises?\s+\w+):\s*(.*)$", line)
        if match:
            if field is not None:
                out.append(" ".join(field))
            if match.group(2):
                field = [f"- `{match.group(2)}`: {match.group(3)}"]
            elif match.group(1).startswith("return"):
                field = [f"- returns: {match.group(3)}"]
            else:
                field = [f"- {match.group(1)}: {match.group(3)}"]
            continue
        if field is not None and line.startswith((" ", "\t")) and line.strip():
            field.append(line.strip())
            continue
        if field is not None:
            out.append(" ".join(field))
            field = None
        out.append(line)
    if field is not None:
        out.append(" ".join(field))
    return _markdown("\n".join(out)).strip()


def _markdown(text: str) -> str:
    text = re.sub(r":(?:class|func|meth|mod|data|attr):`~?([^`]+)`", r"`\1`", text)
    text = text.replace("``", "`")
    return text


def update_file(path: Path) -> bool:
    """Rewrite the reference between the markers of ``path``; True when it changed.

    Raises :class:`ConfigError` when the file or its markers are missing.
    """
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot read {path}: {exc.strerror or exc}", file=str(path)) from None
    new = replace_reference(text, str(path))
    if new == text:
        return False
    path.write_text(new, encoding="utf-8")
    return True


def replace_reference(text: str, where: str = "the document") -> str:
    """``text`` with the part between :data:`BEGIN` and :data:`END` regenerated."""
    return replace_generated(text, BEGIN, END, hook_reference(), where, "hook reference")


class HooksCommand:
    """``armtree hooks``: the hook reference as Markdown, or ``--update FILE`` to rewrite it."""

    help = "print the plugin hook reference (Markdown), or --update docs/plugins.md"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add --update FILE."""
        parser.add_argument(
            "--update",
            metavar="FILE",
            help="rewrite the reference between the markers of FILE (docs/plugins.md)",
        )

    def run(self, args: argparse.Namespace) -> int:
        """Print, or update the file and say whether it changed."""
        if args.update:
            path = Path(args.update)
            changed = update_file(path)
            print(f"{'updated' if changed else 'up to date'}: {path}")
            return 0
        sys.stdout.write(hook_reference())
        return 0


__all__ = ["BEGIN", "END", "HooksCommand", "hook_reference", "replace_reference", "update_file"]
