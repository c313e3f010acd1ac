"""Generated parts of the Markdown docs: the text between two marker comments, regenerated."""

from __future__ import annotations

from armtree.errors import ConfigError


def replace_generated(text: str, begin: str, end: str, content: str, where: str, what: str) -> str:
    """``text`` with ``content`` between the ``begin`` and ``end`` marker lines.

    ``what`` names the generated part in the :class:`ConfigError` raised when
    ``text`` (from ``where``) lacks the markers; the error shows them.
    """
    start, stop = text.find(begin), text.find(end)
    if start < 0 or stop < start:
        raise ConfigError(
            f"{where} has no {what} markers: put the lines\n{begin}\n{end}\n"
            f"where the {what.removesuffix(' reference')} reference belongs",
            file=where,
        )
    return text[: start + len(begin)] + "\n\n" + content + "\n" + text[stop:]
