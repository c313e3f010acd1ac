"""Reading an XML file into elements that know where they, their attributes and their
values were written (1-based line and column), refusing what could expand without bound.

defusedxml's parser refuses a document type declaration outright: BehaviorTree.CPP
files have none, and a DTD is where entity expansion ("billion laughs") and external
entities come from. Files above 2 MB (as YAML tree files), nesting deeper than
:data:`MAX_DEPTH` and more than :data:`MAX_ELEMENTS` elements are refused too, so
nothing later walks an unbounded document.
"""

from __future__ import annotations

import bisect
import re
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree.ElementTree import ParseError

from defusedxml import DTDForbidden, EntitiesForbidden, ExternalReferenceForbidden
from defusedxml.ElementTree import DefusedXMLParser

from armtree import ConfigError
from armtree.config.yamlio import decode, read_bounded
from armtree.errors import Mark

#: Deepest nesting of elements.
MAX_DEPTH = 200
#: Most elements one file may hold.
MAX_ELEMENTS = 50_000

_ATTRIBUTE = re.compile(rb"""([^\s=/>]+)\s*=\s*(["'])""")


@dataclass
class Element:
    """One XML element: its tag, attributes (in file order), children and positions."""

    tag: str
    attrs: dict[str, str]
    mark: Mark
    #: Where each attribute's name and value (after the opening quote) were written.
    name_marks: dict[str, Mark] = field(default_factory=dict)
    value_marks: dict[str, Mark] = field(default_factory=dict)
    children: list[Element] = field(default_factory=list)
    text: str = ""

    def name_mark(self, attr: str) -> Mark:
        """Where attribute ``attr`` was written (the element's position if unknown)."""
        return self.name_marks.get(attr, self.mark)

    def value_mark(self, attr: str) -> Mark:
        """Where the value of attribute ``attr`` starts (else its name's position)."""
        return self.value_marks.get(attr) or self.name_mark(attr)


class _Positions:
    """Line and column of byte offsets in the raw file."""

    def __init__(self, raw: bytes, file: str) -> None:
        self.raw = raw
        self.file = file
        self.starts = [0] + [m.end() for m in re.finditer(rb"\n", raw)]

    def mark(self, offset: int) -> Mark:
        line = bisect.bisect_right(self.starts, offset) - 1
        start = self.starts[line]
        column = len(self.raw[start:offset].decode("utf-8", "replace")) + 1
        return Mark(self.file, line + 1, column)


class _Builder:
    """The parser's target: builds :class:`Element` objects with their positions."""

    def __init__(self, positions: _Positions) -> None:
        self.positions = positions
        self.parser: DefusedXMLParser | None = None
        self.stack: list[Element] = []
        self.root: Element | None = None
        self.count = 0

    def start(self, tag: str, attrs: dict[str, str]) -> None:
        assert self.parser is not None
        offset = self.parser.parser.CurrentByteIndex
        mark = self.positions.mark(offset)
        self.count += 1
        if self.count > MAX_ELEMENTS:
            raise ConfigError(
                f"the file has more than {MAX_ELEMENTS:,} elements; split it",
                mark.file,
                mark.line,
                mark.column,
            )
        if len(self.stack) >= MAX_DEPTH:
            raise ConfigError(
                f"elements nested deeper than {MAX_DEPTH} levels; flatten the tree",
                mark.file,
                mark.line,
                mark.column,
            )
        element = Element(tag, dict(attrs), mark)
        self._attribute_marks(element, offset)
        if self.stack:
            self.stack[-1].children.append(element)
        else:
            self.root = element
        self.stack.append(element)

    def _attribute_marks(self, element: Element, offset: int) -> None:
        raw = self.positions.raw
        end = raw.find(b">", offset)
        tag_text = raw[offset : end if end >= 0 else len(raw)]
        for match in _ATTRIBUTE.finditer(tag_text):
            name = match.group(1).decode("utf-8", "replace")
            if name in element.attrs and name not in element.name_marks:
                element.name_marks[name] = self.positions.mark(offset + match.start(1))
                element.value_marks[name] = self.positions.mark(offset + match.end(2))

    def end(self, tag: str) -> None:
        self.stack.pop()

    def data(self, text: str) -> None:
        if self.stack:
            self.stack[-1].text += text

    def close(self) -> Element | None:
        return self.root


def parse_xml_file(path: Path) -> Element:
    """The root element of the XML file ``path``; :class:`ConfigError` at the line and
    column of malformed XML, a DTD or entity declaration, or a file too large."""
    file = str(path)
    raw = read_bounded(path)
    decode(raw, file)  # a bad byte is an error at its line and column
    return parse_xml(raw, file)


def parse_xml(raw: bytes, file: str) -> Element:
    """The root element of the XML document ``raw`` (the bytes of ``file``)."""
    positions = _Positions(raw, file)
    builder = _Builder(positions)
    parser = DefusedXMLParser(target=builder, forbid_dtd=True)
    builder.parser = parser

    def here() -> Mark:
        expat = parser.parser
        return Mark(file, expat.CurrentLineNumber, expat.CurrentColumnNumber + 1)

    try:
        parser.feed(raw)
        root = parser.close()
    except (DTDForbidden, EntitiesForbidden, ExternalReferenceForbidden):
        doctype = raw.find(b"<!DOCTYPE")
        mark = positions.mark(doctype) if doctype >= 0 else here()
        raise ConfigError(
            "the XML declares a document type (<!DOCTYPE ...>): armtree reads tree files "
            "without DTDs, entities or external references, which can expand without "
            "bound ('billion laughs'); remove the declaration",
            file,
            mark.line,
            mark.column,
        ) from None
    except ParseError as exc:
        line, column = exc.position
        message = str(exc).split(": line", 1)[0]
        raise ConfigError(f"invalid XML: {message}", file, line, column + 1) from None
    if root is None:
        raise ConfigError("the file holds no XML element", file, 1, 1)
    return root
