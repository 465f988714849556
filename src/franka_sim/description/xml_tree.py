"""A URDF's elements as a small tree, read with the standard library's expat parser.

The URDF reader needs only each element's tag, attributes and children. xml.etree would bring
~0.4 MiB of modules into every server, which keeps them for hours, for this one read at start.
"""

from __future__ import annotations

from xml.parsers import expat


class XmlError(ValueError):
    """Not well-formed XML (expat's message: what, line, column)."""


class Element:
    """One element: `tag`, `attrib`, and its child elements in order (text is not kept)."""

    __slots__ = ("tag", "attrib", "children")

    def __init__(self, tag: str, attrib: dict[str, str]) -> None:
        self.tag, self.attrib, self.children = tag, attrib, []

    def get(self, name: str, default: str | None = None) -> str | None:
        return self.attrib.get(name, default)

    def find(self, tag: str) -> Element | None:
        """The first child element with this tag (None: none)."""
        return next((child for child in self.children if child.tag == tag), None)

    def findall(self, tag: str) -> list[Element]:
        """Every child element with this tag, in order."""
        return [child for child in self.children if child.tag == tag]


def parse(text: str) -> Element:
    """The root element of `text`; XmlError if it is not well-formed."""
    parser = expat.ParserCreate()
    open_elements: list[Element] = []
    roots: list[Element] = []

    def start(tag: str, attrib: dict[str, str]) -> None:
        element = Element(tag, attrib)
        (open_elements[-1].children if open_elements else roots).append(element)
        open_elements.append(element)

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda _tag: open_elements.pop()
    try:
        parser.Parse(text, True)
    except expat.ExpatError as exc:
        raise XmlError(str(exc)) from None
    return roots[0]
